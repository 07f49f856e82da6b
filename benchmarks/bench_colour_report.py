"""The colour report of default builds on the J750: errors apart, per model.

Usage: .venv/bin/python benchmarks/bench_colour_report.py
       [--out benchmarks/results/bench_colour_report.json]

Builds the default model and spot, the duck and the airplane at 30 mm (largest side)
with the default rule, materials and halftone on the J750 grid, and keeps each build's
``colour_report`` figures: the in-gamut error inside colour regions (the predicted
colour from ``materials.tif`` against the target), the reproduction error there (the
prediction against the separation's aim: halftone, voxels, depth; what is measurable
where no target is in gamut), the gamut error and the lateral reach of the discs.
A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from report_models import MODELS, ROOT

from shellvox.loading import load_model

KEYS = ("in_gamut_samples", "in_gamut", "reproduction_inside_colour_regions", "gamut")


def main() -> None:
    """Run the builds and write the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks" / "results" / "bench_colour_report.json"
    )
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory() as scratch:
        for name, (path, size_mm) in MODELS.items():
            command = [
                sys.executable,
                "-m",
                "shellvox.cli",
                "build",
                str(path),
                "--printer",
                "j750",
                "--no-progress",
                "-o",
                str(Path(scratch) / name),
            ]
            if size_mm is not None:
                mesh = load_model(path)
                extent = float((mesh.vertices.max(0) - mesh.vertices.min(0)).max())
                command += ["--scale", repr(size_mm / extent)]
            subprocess.run(command, check=True, capture_output=True)
            manifest = json.loads((Path(scratch) / name / "manifest.json").read_text())
            report = manifest["colour_report"]
            results[name] = {key: report[key] for key in (*KEYS, "lateral_reach_mm")}
            print(name, json.dumps(results[name]), flush=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
