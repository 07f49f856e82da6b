"""Deflate encoders on a build's own pages: the fast setting (zlib-ng 2) against zlib level 1.

    python benchmarks/bench_compress.py [BUILD] [--every 20]

Every file a build writes is deflate data, so the encoder's speed is paid per voxel. This
reads the pages of a finished build (``layers.tif``, ``colour.tif``, ``materials.tif``
and the slices of ``job.gcvf``; without BUILD, spot at 35 mm on the J750 grid is built
first), compresses every ``--every``-th one again with each encoder in this process
(zlib level 1, the peer; the fast setting; the run encoder; ISA-L where installed),
checks each stream inflates (zlib) to the page's bytes, and reports milliseconds and
bytes per page, the ratios to zlib's level 1, and the time zlib takes to inflate each
encoder's pages (what a reader pays).
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tempfile
import time
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import tifffile
from PIL import Image

try:  # not a dependency (see voxel/io/_compression.py): measured where installed
    from isal import isal_zlib
except ImportError:
    isal_zlib = None

from _common import mesh_path, parser, scale_for, write_result

from shellvox.voxel.io import compress, zlib_compress

NAME = "bench_compress"
WHAT = (
    "Milliseconds and bytes per page of the build's deflate encoders (the fast "
    "setting, zlib-ng level 2, and the run encoder) on a build's own pages, against "
    "zlib level 1 in the same process."
)


def _pages(build: Path, every: int) -> dict[str, tuple[list[bytes], int]]:
    """Raw bytes of the chosen pages of each stack, and the run encoder's period."""
    pages: dict[str, tuple[list[bytes], int]] = {}
    for name, period in (("layers.tif", 1), ("colour.tif", 3), ("materials.tif", 1)):
        path = build / name
        if path.exists():
            with tifffile.TiffFile(path) as tiff:
                n = len(tiff.pages)
                arrays = [tiff.pages[i].asarray() for i in range(0, n, every)]
            pages[name] = ([a.tobytes() for a in arrays], period)
    job = build / "job.gcvf"
    if job.exists():
        with zipfile.ZipFile(job) as archive:
            names = [n for n in archive.namelist() if n.endswith(".png")][::every]
            rows = []
            for name in names:
                with Image.open(io.BytesIO(archive.read(name))) as image:
                    pixels = np.asarray(image)
                height = pixels.shape[0]
                row = np.zeros((height, 1 + pixels[0].size), np.uint8)  # PNG filter 0
                row[:, 1:] = pixels.reshape(height, -1)
                rows.append(row.tobytes())
            pages["job.gcvf slices"] = (rows, 4)
    return pages


def _time(encode: Callable[[bytes], bytes], pages: list[bytes]) -> dict[str, float]:
    encode(pages[0])  # compiled on first use (the run encoder)
    tick = time.perf_counter()
    streams = [encode(page) for page in pages]
    seconds = time.perf_counter() - tick
    tick = time.perf_counter()
    inflated = [zlib.decompress(s) for s in streams]
    inflate_s = time.perf_counter() - tick
    if inflated != pages:
        raise AssertionError("a stream does not inflate to its page")
    row = {
        "ms_per_page": round(1e3 * seconds / len(pages), 3),
        "bytes_per_page": round(sum(map(len, streams)) / len(pages)),
        "zlib_inflate_ms_per_page": round(1e3 * inflate_s / len(pages), 3),
    }
    return row


def build(out: Path, quick: bool) -> None:
    """Build spot at 35 mm on the J750 grid into `out` (quick: 5 mm) to read its pages."""
    size = 5.0 if quick else 35.0
    command = [
        sys.executable, "-m", "shellvox.cli", "build", str(mesh_path("spot")), "-o", str(out),
        "--printer", "j750", "--scale", repr(scale_for("spot", size)), "--no-progress",
        "--format", "tiff,gcvf",
    ]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True)


def measure(build: Path, every: int) -> dict[str, Any]:
    results: dict[str, Any] = {"every": every, "stacks": {}}
    for name, (pages, period) in _pages(build, every).items():
        row: dict[str, Any] = {"pages": len(pages), "raw_bytes_per_page": len(pages[0])}
        row["zlib-1"] = _time(lambda b: zlib.compress(b, 1), pages)
        row["fast (zlib-ng 2)"] = _time(compress, pages)
        row["run encoder"] = _time(lambda b, p=period: zlib_compress(b, p), pages)
        peer = row["zlib-1"]
        row["fast time / zlib-1"] = round(
            row["fast (zlib-ng 2)"]["ms_per_page"] / peer["ms_per_page"], 3
        )
        row["fast size / zlib-1"] = round(
            row["fast (zlib-ng 2)"]["bytes_per_page"] / peer["bytes_per_page"], 3
        )
        if isal_zlib is not None:
            row["isal-1"] = _time(lambda b: isal_zlib.compress(b, 1), pages)
            row["isal time / zlib-1"] = round(row["isal-1"]["ms_per_page"] / peer["ms_per_page"], 3)
            row["isal size / zlib-1"] = round(
                row["isal-1"]["bytes_per_page"] / peer["bytes_per_page"], 3
            )
        results["stacks"][name] = row
        print(name, json.dumps(row), flush=True)
    return results


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    return [
        {
            "stack": name,
            "pages": row["pages"],
            "raw_bytes_per_page": row["raw_bytes_per_page"],
            "zlib1_ms_per_page": row["zlib-1"]["ms_per_page"],
            "fast_ms_per_page": row["fast (zlib-ng 2)"]["ms_per_page"],
            "fast_time_over_zlib1": row["fast time / zlib-1"],
            "fast_size_over_zlib1": row["fast size / zlib-1"],
            "run_encoder_ms_per_page": row["run encoder"]["ms_per_page"],
        }
        for name, row in details["stacks"].items()
    ]


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("build", nargs="?", type=Path, help="a build's output folder")
    parsed.add_argument("--every", type=int, default=20, help="take every N-th page")
    args = parsed.parse_args()
    if args.build is not None:
        details = {"build": str(args.build), **measure(args.build, args.every)}
    else:
        with tempfile.TemporaryDirectory() as folder:
            build(Path(folder) / "build", args.quick)
            details = {
                "build": "spot at 35 mm on the J750 grid (--format tiff,gcvf)"
                if not args.quick
                else "spot at 5 mm on the J750 grid (--format tiff,gcvf)",
                **measure(Path(folder) / "build", 1 if args.quick else args.every),
            }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
