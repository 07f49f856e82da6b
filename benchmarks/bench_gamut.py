"""Which targets the J750's assumed materials can reach: the separation against brute force.

Usage: .venv/bin/python benchmarks/bench_gamut.py [--out benchmarks/results/bench_gamut.json]

For each model of :mod:`report_models`, at 5,000 surface samples: the CIEDE2000 between
each target (sRGB to CIELAB under D50) and the deep colour of its separation's mix (the
gamut error), and the least CIEDE2000 over 120,000 random mixes of the opaque materials
(Dirichlet, concentrations 0.1, 0.3 and 1; the 32 nearest in CIELAB of each target), for
every sample and for the five most frequent target colours.
Where that least error is also large the target lies outside the gamut of the optics,
whatever the separation does. A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import colour
import numpy as np
from report_models import MODELS, ROOT
from scipy.spatial import cKDTree

from shellvox.config import MaterialSettings
from shellvox.loading import load_model
from shellvox.printer import build_material_plan, layer_model, load_profile
from shellvox.thickness import DEFAULT_RULE
from shellvox.voxel.colour import observer, sample_surface, srgb_to_lab_d50

SAMPLES = 5_000
RANDOM_MIXES = 40_000  # per concentration


def main() -> None:
    """Measure every model and write the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/bench_gamut.json")
    args = parser.parse_args()
    rule, profile = DEFAULT_RULE, load_profile("j750")
    plan = build_material_plan(
        profile, MaterialSettings(), colour_layers=rule.layers.colour, n_bands=rule.layers.n_layers
    )
    model = layer_model(profile, plan, rule.layers.backing_mm)
    opaque = [i for i, role in enumerate(plan.separation.roles) if role != "clear"]
    rng = np.random.default_rng(0)
    mixes = np.zeros((3 * RANDOM_MIXES, len(plan.separation.roles)))
    mixes[:, opaque] = np.concatenate(
        [rng.dirichlet(np.full(len(opaque), a), RANDOM_MIXES) for a in (0.1, 0.3, 1.0)]
    )
    reachable = model.deep_lab(mixes)
    tree = cKDTree(reachable)
    white = observer(profile.optics.wavelengths_nm).white_xy  # the separation's white
    results: dict[str, Any] = {}
    for name, (path, _) in MODELS.items():  # the colours do not depend on the size
        mesh = load_model(path)
        points = sample_surface(mesh.vertices, mesh.faces, mesh.colour_at, SAMPLES, seed=0)
        rgba = points.target_rgba
        target = srgb_to_lab_d50(rgba[:, :3] / 255.0, white)
        shares = model.shares(rgba)
        gamut = colour.delta_E(model.deep_lab(shares), target, method="CIE 2000")
        _, near = tree.query(target, k=32)
        least_all = colour.delta_E(reachable[near], target[:, None], method="CIE 2000").min(1)
        colours, inverse = np.unique(rgba[:, :3], axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        counts = np.bincount(inverse)
        frequent = []
        for i in np.argsort(-counts)[:5]:  # loop over five colours
            first = int(np.flatnonzero(inverse == i)[0])
            least = least_all[first]
            frequent.append(
                {
                    "srgb": colours[i].tolist(),
                    "share_of_surface": round(float(counts[i] / SAMPLES), 4),
                    "lab_d50": np.round(target[first], 2).tolist(),
                    "separation_de00": round(float(gamut[first]), 3),
                    "least_of_random_mixes_de00": round(float(least), 3),
                }
            )
        results[name] = {
            "gamut_de00": {
                "median": round(float(np.median(gamut)), 3),
                "p95": round(float(np.percentile(gamut, 95)), 3),
                "share_within_1": round(float((gamut <= 1.0).mean()), 4),
            },
            "least_of_random_mixes_de00": {
                "median": round(float(np.median(least_all)), 3),
                "share_within_1": round(float((least_all <= 1.0).mean()), 4),
            },
            "most_frequent_colours": frequent,
        }
        print(name, json.dumps(results[name]), flush=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
