"""Build time and bytes on disk with the OME-Zarr store in place of the TIFFs.

    python benchmarks/bench_zarr_build.py [--size-mm 100] [--rounds 1] [--keep DIR]

``shellvox build`` of spot (largest extent ``--size-mm``, the J750 default grid) with the
TIFFs (``tiff,vdb,gcvf``), with the store in their place (``zarr,vdb,gcvf``) and with both
(``tiff,zarr,vdb,gcvf``, the default formats), alternating in one run (the TIFFs alone
are the peer), each a child
process under ``/usr/bin/time -v``: wall time, the manifest's seconds (``slabs`` among
them), peak RSS, bytes and files on disk (the store's and the TIFFs' apart). ``--keep
DIR`` keeps the last build with both as ``DIR`` (for ``bench_viewer.py``). The load
average before and after each build is recorded: the machine may be shared.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import trimesh
from _common import mesh_path, parser, write_result

NAME = "bench_zarr_build"
WHAT = (
    "Build time, peak memory and bytes on disk of shellvox build of spot at 100 mm with "
    "the OME-Zarr store in place of the TIFFs and with both, against the TIFFs alone, "
    "alternating in one session."
)
#: The store in place of the TIFFs, the TIFFs alone (the default before the store joined
#: it) and both (the default since).
FORMATS = ("zarr,vdb,gcvf", "tiff,vdb,gcvf", "tiff,zarr,vdb,gcvf")


def _size(folder: Path, pattern: str) -> tuple[int, int]:
    """Bytes and number of the files under `folder` matching `pattern` (a glob)."""
    files = [p for p in folder.glob(pattern) if p.is_file()]
    return sum(p.stat().st_size for p in files), len(files)


def build(model: Path, scale: float, formats: str, out: Path) -> dict[str, Any]:
    """Run one build as a child process and return its measurements."""
    command = [
        "/usr/bin/time", "-v", sys.executable, "-m", "shellvox.cli", "build", str(model),
        "-o", str(out), "--scale", repr(scale), "--format", formats, "--no-progress",
    ]  # fmt: skip
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
    manifest = json.loads((out / "manifest.json").read_text())
    everything = _size(out, "**/*")
    store = _size(out, "stack.ome.zarr/**/*")
    tiffs = _size(out, "*.tif")
    return {
        "formats": formats,
        "wall_s": round(wall, 1),
        "seconds": {k: round(float(v), 1) for k, v in manifest["seconds"].items()},
        "peak_rss_mb_largest_process": int(peak.group(1)) // 1024 if peak else None,
        "bytes_on_disk": everything[0],
        "files": everything[1],
        "store_bytes": store[0],
        "store_files": store[1],
        "tiff_bytes": tiffs[0],
        "tiff_files": tiffs[1],
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "slab_rows": manifest["slab_rows"],
        "load_average": [round(load_before, 1), round(os.getloadavg()[0], 1)],
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per run: its formats, times, memory and bytes."""
    return [
        {
            "formats": run["formats"],
            "wall_s": run["wall_s"],
            "slabs_s": run["seconds"].get("slabs"),
            "peak_rss_mb": run["peak_rss_mb_largest_process"],
            "on_disk_mb": round(run["bytes_on_disk"] / 1e6, 1),
            "store_mb": round(run["store_bytes"] / 1e6, 1),
            "tiff_mb": round(run["tiff_bytes"] / 1e6, 1),
            "files": run["files"],
        }
        for run in details["runs"]
    ]


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--size-mm", type=float, default=100.0)
    parsed.add_argument("--rounds", type=int, default=1)
    parsed.add_argument("--keep", type=Path, help="keep the last build with both here")
    args = parsed.parse_args()
    if args.quick:
        args.size_mm = 5.0
    spot = mesh_path("spot")
    scale = args.size_mm / float(max(trimesh.load(spot, process=False).extents))
    runs = []
    with tempfile.TemporaryDirectory(dir=args.keep.parent if args.keep else None) as work:
        for round_ in range(args.rounds):
            for formats in FORMATS:
                out = Path(work) / f"{round_}_{formats.replace(',', '_')}"
                runs.append(build(spot, scale, formats, out))
                print(json.dumps(runs[-1]), flush=True)
                if args.keep and formats == FORMATS[-1]:
                    shutil.rmtree(args.keep, ignore_errors=True)
                    out.rename(args.keep)
                else:
                    shutil.rmtree(out)
    details = {
        "model": f"spot at {args.size_mm:g} mm, the J750 grid",
        "command": f"shellvox build spot_triangulated.obj --scale {scale!r} --format F "
        "--no-progress, under /usr/bin/time -v, alternating",
        "date": time.strftime("%Y-%m-%d"),
        "runs": runs,
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
