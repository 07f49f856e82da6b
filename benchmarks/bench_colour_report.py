"""The colour report of default builds on the J750: its errors apart, per model.

    python benchmarks/bench_colour_report.py

Builds the default model and spot, the duck and the airplane at 30 mm (largest side)
with ``shellvox build MODEL --printer j750`` (the default rule, materials and halftone),
each a child process, and keeps each build's ``colour_report`` figures (CIEDE2000): the
in-gamut error inside colour regions (the colour predicted from ``materials.tif``
against the target), the reproduction error there (the prediction against the
separation's aim: halftone, voxels, depth; what is measurable where no target is in
gamut), the gamut error and the lateral reach of the discs. There is no external peer:
the reference is the model's own colour.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import COLOUR_MODELS, mesh_path, parser, scale_for, write_result

NAME = "bench_colour_report"
WHAT = (
    "CIEDE2000 of the colour report of default J750 builds per model (the predicted "
    "colour of materials.tif against the target where in gamut, against the "
    "separation's aim, and the gamut error); no external peer."
)
KEYS = ("in_gamut_samples", "in_gamut", "reproduction_inside_colour_regions", "gamut")


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for model, report in details["models"].items():
        rows.append(
            {
                "model": model,
                "in_gamut_samples": report["in_gamut_samples"],
                "in_gamut_median": report["in_gamut"]["median"],
                "in_gamut_p95": report["in_gamut"]["p95"],
                "reproduction_median": report["reproduction_inside_colour_regions"]["median"],
                "reproduction_p95": report["reproduction_inside_colour_regions"]["p95"],
                "gamut_median": report["gamut"]["median"],
                "gamut_p95": report["gamut"]["p95"],
                "lateral_reach_median_mm": report["lateral_reach_mm"]["median"],
            }
        )
    return rows


def main() -> None:
    args = parser(__doc__).parse_args()
    models = {"default": ("default", None)} if args.quick else COLOUR_MODELS
    results = {}
    with tempfile.TemporaryDirectory() as scratch:
        for name, (mesh, size_mm) in models.items():
            out = Path(scratch) / name
            command = [
                sys.executable, "-m", "shellvox.cli", "build", str(mesh_path(mesh)),
                "--printer", "j750", "--no-progress", "-o", str(out),
                "--scale", repr(scale_for(mesh, size_mm)),
            ]  # fmt: skip
            if args.quick:  # off the printer's grid: no job, the report all the same
                command += ["--voxel-size", "0.2,0.2,0.2", "--format", "tiff"]
            subprocess.run(command, check=True, capture_output=True)
            report = json.loads((out / "manifest.json").read_text())["colour_report"]
            results[name] = {key: report[key] for key in (*KEYS, "lateral_reach_mm")}
            print(name, json.dumps(results[name]), flush=True)
    details = {
        "setup": "shellvox build MODEL --printer j750 --scale S (largest side 30 mm; the "
        "default model at its own size); CIEDE2000 of the manifest's colour_report",
        "models": results,
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
