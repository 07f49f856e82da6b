"""Write a printable calibration chart: the job, chart.json (its patches) and a preview."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from pipeline import __version__
from pipeline.atomic import atomic_path, write_text_atomic
from pipeline.errors import InputError
from pipeline.output import OutputFolder, gcvf_writer
from pipeline.printer import (
    ChartLayout,
    PrinterProfile,
    chart_json,
    chart_layout,
    chart_preview,
    chart_slab,
    load_profile,
    profile_text,
)
from voxel.io import PngSliceWriter

#: What ``chart`` writes (``chart.json`` last: the folder's complete-run marker).
CHART_OUTPUTS = ("chart.json", "job.gcvf", "preview/chart.png", "slices/*")
#: Slices made and written at a time.
SLAB_SLICES = 16


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``chart``'s arguments."""
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="DIR")
    parser.add_argument(
        "--printer", default="j750", metavar="P", help="printer profile: shipped name or .toml"
    )


def run(args: argparse.Namespace) -> int:
    """Write DIR/job.gcvf (or DIR/slices/), DIR/preview/chart.png and DIR/chart.json."""
    out: Path = args.output
    profile = load_profile(args.printer)
    try:
        layout = chart_layout(profile)
    except ValueError as error:
        raise InputError(
            f"--printer {args.printer}", str(error), "use a profile with both"
        ) from None
    content = chart_json(layout, profile, profile_text(args.printer))
    with OutputFolder(out, CHART_OUTPUTS, marker="chart.json") as folder:
        if profile.slice_format == "gcvf":
            files = [_write_job(out / "job.gcvf", layout, profile)]
        else:
            files = _write_slices(out / "slices", layout, profile)
        (out / "preview").mkdir(exist_ok=True)
        with atomic_path(out / "preview" / "chart.png") as temporary:
            chart_preview(layout, profile).save(temporary, format="PNG")
        files.append(out / "preview" / "chart.png")
        content["files"] = folder.commit(files)
        write_text_atomic(out / "chart.json", json.dumps(content, indent=1))
    z, y, x = layout.grid.shape_zyx
    vx, vy, vz = layout.grid.voxel_mm
    print(
        f"chart of {len(layout.patches)} patches, {x * vx:.1f} x {y * vy:.1f} x {z * vz:.2f} mm "
        f"({x} x {y} x {z} voxels) for {profile.name}"
    )
    job = out / ("job.gcvf" if profile.slice_format == "gcvf" else "slices")
    for path in (job, out / "preview" / "chart.png", out / "chart.json"):
        print(path)
    return 0


def _write_job(path: Path, layout: ChartLayout, profile: PrinterProfile) -> Path:
    table = [(m.index, m.job_name, m.rgba_key) for m in profile.materials[1:]]
    with atomic_path(path) as temporary:
        writer = gcvf_writer(temporary, layout.grid, table, profile)
        with writer:
            for z0 in range(0, layout.grid.shape_zyx[0], SLAB_SLICES):  # loop over slabs
                writer.write_slab(
                    chart_slab(layout, z0, min(z0 + SLAB_SLICES, layout.grid.shape_zyx[0]))
                )
    return path


def _write_slices(folder: Path, layout: ChartLayout, profile: PrinterProfile) -> list[Path]:
    display = np.zeros((256, 4), np.uint8)
    for material in profile.materials[1:]:
        display[material.index] = (*material.display_srgb, 255)
    metadata = {"creator": f"shellvox {__version__}", "printer": profile.name, "chart": True}
    with PngSliceWriter(folder, layout.grid, metadata=metadata) as writer:
        for z0 in range(0, layout.grid.shape_zyx[0], SLAB_SLICES):  # loop over slabs
            writer.write_slab(
                display[chart_slab(layout, z0, min(z0 + SLAB_SLICES, layout.grid.shape_zyx[0]))]
            )
    return sorted(p for p in folder.iterdir() if p.is_file())
