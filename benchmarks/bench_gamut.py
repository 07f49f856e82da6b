"""Which targets the J750's assumed materials can reach: the separation against brute force.

    python benchmarks/bench_gamut.py

For the default model and spot, the duck and the airplane, at 5,000 surface samples: the
CIEDE2000 between each target (sRGB to CIELAB under D50) and the deep colour of its
separation's mix (the gamut error), and the least CIEDE2000 over 120,000 random mixes of
the opaque materials (Dirichlet, concentrations 0.1, 0.3 and 1; the 32 nearest in CIELAB
of each target), for every sample and for the five most frequent target colours (the peer:
brute force). Where that least error is also large the target lies outside the gamut of
the optics, whatever the separation does.
"""

from __future__ import annotations

import json
from typing import Any

import colour
import numpy as np
from _common import COLOUR_MODELS, mesh_path, parser, write_result
from scipy.spatial import cKDTree

from shellvox.config import MaterialSettings
from shellvox.loading import load_model
from shellvox.printer import build_material_plan, layer_model, load_profile
from shellvox.thickness import DEFAULT_RULE
from shellvox.voxel.colour import observer, sample_surface, srgb_to_lab_d50

NAME = "bench_gamut"
WHAT = (
    "CIEDE2000 between each surface target and its separation's deep colour on the "
    "J750's assumed materials, against the least error of 120,000 random material "
    "mixes (brute force)."
)


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    return [
        {
            "model": name,
            "separation_median": row["gamut_de00"]["median"],
            "separation_p95": row["gamut_de00"]["p95"],
            "separation_share_within_1": row["gamut_de00"]["share_within_1"],
            "brute_force_median": row["least_of_random_mixes_de00"]["median"],
            "brute_force_share_within_1": row["least_of_random_mixes_de00"]["share_within_1"],
        }
        for name, row in details["models"].items()
    ]


def main() -> None:
    """Measure every model and write the figures."""
    args = parser(__doc__).parse_args()
    samples = 500 if args.quick else 5_000
    random_mixes = 4_000 if args.quick else 40_000  # per concentration
    rule, profile = DEFAULT_RULE, load_profile("j750")
    plan = build_material_plan(
        profile, MaterialSettings(), colour_layers=rule.layers.colour, n_bands=rule.layers.n_layers
    )
    model = layer_model(profile, plan, rule.layers.backing_mm)
    opaque = [i for i, role in enumerate(plan.separation.roles) if role != "clear"]
    rng = np.random.default_rng(0)
    mixes = np.zeros((3 * random_mixes, len(plan.separation.roles)))
    mixes[:, opaque] = np.concatenate(
        [rng.dirichlet(np.full(len(opaque), a), random_mixes) for a in (0.1, 0.3, 1.0)]
    )
    reachable = model.deep_lab(mixes)
    tree = cKDTree(reachable)
    white = observer(profile.optics.wavelengths_nm).white_xy  # the separation's white
    results: dict[str, Any] = {}
    models = {"default": COLOUR_MODELS["default"]} if args.quick else COLOUR_MODELS
    for name, (shared, _) in models.items():  # the colours do not depend on the size
        mesh = load_model(mesh_path(shared))
        points = sample_surface(mesh.vertices, mesh.faces, mesh.colour_at, samples, seed=0)
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
                    "share_of_surface": round(float(counts[i] / samples), 4),
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
    details = {
        "setup": f"J750 profile, default rule and materials; {samples} surface samples; "
        f"{3 * random_mixes} random mixes of the opaque materials (Dirichlet, concentrations "
        "0.1, 0.3, 1), the 32 nearest in CIELAB of each target; CIEDE2000",
        "models": results,
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
