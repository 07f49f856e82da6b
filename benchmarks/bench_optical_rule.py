"""What the optical thickness rule buys against one constant depth, under the model.

    python benchmarks/bench_optical_rule.py [--samples 20000]

For the default model, spot (30 mm) and the duck (30 mm) on the J750, with the profile's
optics and with every material's scattering scaled by 0.5 and by 2 (the rule and the
separation recomputed for each): the thickness of the optical rule, then at 20,000
surface samples (:func:`shellvox.voxel.colour._depth_effect.depth_effect`): the share of the
surface within delta_e of its settled colour with the rule's depths and with one
constant depth of the same mean (the peer), and the mean depth each needs for 95 % of
the surface. The model only, no voxels: what the rule is meant to do.
"""

from __future__ import annotations

import dataclasses
import json
import time
from typing import Any

from _common import COLOUR_MODELS, mesh_path, parser, write_result

from shellvox.config import MaterialSettings
from shellvox.loading import load_model
from shellvox.model import ColouredMesh
from shellvox.printer import PrinterProfile, build_material_plan, layer_model, load_profile
from shellvox.thickness import DEFAULT_RULE, face_thickness
from shellvox.voxel.colour import depth_effect, sample_surface

NAME = "bench_optical_rule"
WHAT = (
    "Share of the surface within delta_e of its settled colour with the optical "
    "thickness rule's depths against one constant depth of the same mean (the model "
    "only, no voxels), and the constant depth needed for the same coverage."
)
MODELS = {name: COLOUR_MODELS[name] for name in ("default", "spot_30mm", "duck_30mm")}


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


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for key, row in details["cases"].items():
        model, scattering = key.split(" S x")
        rows.append(
            {
                "model": model,
                "scattering": f"x{scattering}",
                "rule_mean_depth_mm": row["mean_depth_mm"],
                "covered_by_rule": row["adaptive"]["covered_share"],
                "covered_by_constant": row["constant"]["covered_share"],
                "constant_over_rule_for_95pct": row["for_95_percent"]["constant_over_adaptive"],
                "constant_over_rule_same_coverage": row["for_same_coverage"][
                    "constant_over_adaptive"
                ],
            }
        )
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--samples", type=int, default=20_000)
    args = parsed.parse_args()
    models = {"default": MODELS["default"]} if args.quick else MODELS
    samples = 2_000 if args.quick else args.samples
    base = load_profile("j750")
    results: dict[str, Any] = {}
    for factor in (1.0,) if args.quick else (1.0, 0.5, 2.0):
        profile = base if factor == 1.0 else _with_scattering(base, factor)
        for name, (shared, size) in models.items():
            mesh = _scaled(load_model(mesh_path(shared)), size)
            key = f"{name} S x{factor:g}"
            results[key] = one(mesh, profile, samples)
            print(key, json.dumps(results[key]), flush=True)
    details = {
        "setup": f"J750 profile (scattering as shipped, x0.5, x2), default rule; {samples} "
        "surface samples; delta_e of the rule's colour layer",
        "cases": results,
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
