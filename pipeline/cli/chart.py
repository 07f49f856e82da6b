"""Write a printable calibration chart: the job, chart.json (its patches) and a preview."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``chart``'s arguments."""
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    parser.add_argument(
        "--printer", default="j750", metavar="P", help="printer profile: shipped name or .toml"
    )


def run(args: argparse.Namespace) -> int:
    """Write DIR/job.gcvf (or DIR/slices/), DIR/preview/chart.png and DIR/chart.json."""
    from shellvox.api import make_chart

    out: Path = args.output
    chart = make_chart(out, printer=args.printer)
    layout = chart.layout
    z, y, x = layout.grid.shape_zyx
    vx, vy, vz = layout.grid.voxel_mm
    print(
        f"chart of {len(layout.patches)} patches, {x * vx:.1f} x {y * vy:.1f} x {z * vz:.2f} mm "
        f"({x} x {y} x {z} voxels) for {chart.printer}"
    )
    job = out / ("job.gcvf" if (out / "job.gcvf") in chart.files else "slices")
    for path in (job, out / "preview" / "chart.png", out / "chart.json"):
        print(path)
    return 0
