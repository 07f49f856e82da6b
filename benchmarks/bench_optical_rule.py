"""What the optical thickness rule buys against one constant depth, under the model.

Usage: .venv/bin/python benchmarks/bench_optical_rule.py
       [--out benchmarks/results/bench_optical_rule.json] [--samples 20000]

For the default model, spot (30 mm) and the duck (30 mm) on the J750, with the profile's
optics and with every material's scattering scaled by 0.5 and by 2 (the rule and the
separation recomputed for each): the thickness of the optical rule, then at 20,000
surface samples (:func:`shellvox.voxel.colour._depth_effect.depth_effect`): the share of the
surface within delta_e of its settled colour with the rule's depths and with one
constant depth of the same mean, and the mean depth each needs for 95 % of the surface.
The model only, no voxels: what the rule is meant to do. A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

from report_models import MODELS as ALL_MODELS
from report_models import ROOT

from shellvox.config import MaterialSettings
from shellvox.loading import load_model
from shellvox.model import ColouredMesh
from shellvox.printer import PrinterProfile, build_material_plan, layer_model, load_profile
from shellvox.thickness import DEFAULT_RULE, face_thickness
from shellvox.voxel.colour import depth_effect, sample_surface

MODELS = {name: ALL_MODELS[name] for name in ("default", "spot_30mm", "duck_30mm")}


def _scaled(mesh: ColouredMesh, size_mm: float | None) -> ColouredMesh:
    if size_mm is None:
        return mesh
    extent = float((mesh.vertices.max(0) - mesh.vertices.min(0)).max())
    return dataclasses.replace(mesh, vertices=mesh.vertices * (size_mm / extent))


def _with_scattering(profile: PrinterProfile, factor: float) -> PrinterProfile:
    optics = dataclasses.replace(profile.optics, s_per_mm=profile.optics.s_per_mm * factor)
    return dataclasses.replace(profile, optics=optics)


def one(mesh: ColouredMesh, profile: PrinterProfile, samples: int) -> dict[str, Any]:
    """Return the rule's depths and their effect for one model and one set of optics."""
    rule = DEFAULT_RULE
    plan = build_material_plan(
        profile, MaterialSettings(), colour_layers=rule.layers.colour,
        n_bands=rule.layers.n_layers,
    )  # fmt: skip
    model = layer_model(profile, plan, rule.layers.backing_mm)
    tick = time.perf_counter()
    faces = face_thickness(mesh, rule, model=model)
    rule_s = time.perf_counter() - tick
    points = sample_surface(mesh.vertices, mesh.faces, mesh.colour_at, samples, seed=0)
    shares = model.shares(points.target_rgba)
    depth = faces.colour_layer_mm[points.face_ids]
    effect = depth_effect(model, shares, depth, delta_e=rule.colour_layer.delta_e)
    return {"faces": mesh.n_faces, "rule_seconds": round(rule_s, 2), **effect}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks/results/bench_optical_rule.json"
    )
    parser.add_argument("--samples", type=int, default=20_000)
    args = parser.parse_args()
    base = load_profile("j750")
    results: dict[str, Any] = {}
    for factor in (1.0, 0.5, 2.0):
        profile = base if factor == 1.0 else _with_scattering(base, factor)
        for name, (path, size) in MODELS.items():
            mesh = _scaled(load_model(path), size)
            key = f"{name} S x{factor:g}"
            results[key] = one(mesh, profile, args.samples)
            print(key, json.dumps(results[key]))
    args.out.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
