"""Speed and memory of the printer-slice writers on J750 slices of spot at 100 mm.

    python benchmarks/bench_slices.py [--slices 96] [--slab 24]

Slices are 1322 x 1176 voxels (x, y: the grid of spot scaled to 100 mm on the J750) with a
synthetic model: an elliptic section whose size varies with z, a white core, and a 1 mm
skin halftoned at random among five materials (the worst case for compression). Measured:
one slice encoded by :func:`shellvox.voxel.io._png_encode.encode_png` and by Pillow
(``compress_level=1``, the peer); :class:`shellvox.voxel.io._gcvf_writer.GcvfWriter` with
1 and 2 encoding threads (slices/s, MB/s of RGBA pixels, bytes per slice); the peak of
traced memory (numpy allocations) while writing `--slices` and four times as many, which
must not grow with the height; :class:`shellvox.voxel.io._png_slices.PngSliceWriter`; and
the time the ``material`` grid adds to
:class:`shellvox.voxel.io.vdb._writer.VdbStackWriter`.
"""

from __future__ import annotations

import io
import json
import tempfile
import time
import tracemalloc
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from _common import parser, write_result
from PIL import Image

from shellvox.printer import load_profile
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import GcvfWriter, PngSliceWriter, encode_png
from shellvox.voxel.io.vdb import VdbStackWriter

NAME = "bench_slices"
WHAT = (
    "Speed and memory of the printer-slice writers on synthetic J750 slices of spot "
    "at 100 mm (1322 x 1176 voxels): the PNG encoder against Pillow's level 1, the "
    "job writer with 1 and 2 threads, the PNG folder, and the VDB's material grid."
)

N_Y, N_X = 1176, 1322
TABLE = [
    (1, "VeroCyan-V", (0, 255, 255, 255)),
    (2, "VeroMagenta-V", (255, 0, 255, 255)),
    (3, "VeroYellow-V", (255, 255, 0, 255)),
    (4, "VeroBlack", (1, 1, 1, 255)),
    (5, "VeroPureWhite", (255, 255, 255, 255)),
    (6, "VeroClear", (137, 137, 137, 255)),
]


def slabs(n_z: int, rows: int, seed: int = 0) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Yield ``(z0, materials (Zs, Y, X) uint8, layers (Zs, Y, X) uint8)``."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:N_Y, 0:N_X].astype(np.float32)
    for z0 in range(0, n_z, rows):
        count = min(rows, n_z - z0)
        materials = np.zeros((count, N_Y, N_X), np.uint8)
        layers = np.zeros_like(materials)
        for k in range(count):
            scale = 0.3 + 0.15 * np.sin((z0 + k) / 200.0)
            r = np.hypot((x - N_X / 2) / (scale * N_X), (y - N_Y / 2) / (scale * N_Y))
            inside = r < 1.0
            skin = inside & (r > 1.0 - 24.0 / (scale * N_X))  # about 1 mm of 42 um voxels
            materials[k][inside] = 5
            materials[k][skin] = rng.integers(1, 7, int(skin.sum()))
            layers[k][inside] = 3
            layers[k][skin] = 1
        yield z0, materials, layers


def timed(function: Callable[[], object], repeat: int = 5) -> float:
    function()
    start = time.perf_counter()
    for _ in range(repeat):
        function()
    return (time.perf_counter() - start) / repeat


def one_slice() -> dict[str, object]:
    _, materials, _ = next(slabs(1, 1))
    lut = np.zeros((256, 4), np.uint8)
    lut[:, 3] = 255
    for index, _, key in TABLE:
        lut[index] = key
    rgba = lut[materials[0]]
    ours = timed(lambda: encode_png(rgba, level=1))
    pillow = timed(
        lambda: Image.fromarray(rgba, "RGBA").save(io.BytesIO(), "PNG", compress_level=1)
    )
    buffer = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buffer, "PNG", compress_level=1)
    return {
        "slice_xy": [N_X, N_Y],
        "encode_png_ms": round(ours * 1e3, 1),
        "encode_png_mb_per_s": round(rgba.nbytes / ours / 1e6),
        "encode_png_kb": round(len(encode_png(rgba, level=1)) / 1e3),
        "pillow_level1_ms": round(pillow * 1e3, 1),
        "pillow_level1_kb": round(len(buffer.getvalue()) / 1e3),
    }


def gcvf(n_z: int, rows: int, threads: int, folder: Path) -> dict[str, object]:
    grid = GridSpec((0.0, 0.0, 0.0), load_profile("j750").voxel_mm, (n_z, N_Y, N_X))
    data = list(slabs(min(n_z, 2 * rows), rows))  # made once, outside the timing
    path = folder / "job.gcvf"
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    start = time.perf_counter()
    with GcvfWriter(path, grid, TABLE, threads=threads) as job:
        for z0 in range(0, n_z, rows):
            job.write_slab(data[(z0 // rows) % len(data)][1][: n_z - z0])
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    return {
        "slices": n_z,
        "threads": threads,
        "seconds": round(seconds, 2),
        "slices_per_s": round(n_z / seconds, 1),
        "rgba_mb_per_s": round(n_z * N_Y * N_X * 4 / seconds / 1e6),
        "bytes_per_slice": round(path.stat().st_size / n_z),
        "peak_traced_mb_above_input": round(peak / 1e6, 1),
        "slab_mb": round(rows * N_Y * N_X / 1e6, 1),
    }


def png_folder(n_z: int, rows: int, folder: Path) -> dict[str, object]:
    grid = GridSpec((0.0, 0.0, 0.0), load_profile("j750").voxel_mm, (n_z, N_Y, N_X))
    colours = np.array(
        [
            (0, 0, 0, 0),
            (0, 160, 200, 255),
            (200, 30, 120, 255),
            (230, 200, 0, 255),
            (20, 20, 20, 255),
            (240, 240, 240, 255),
            (200, 200, 200, 128),
        ],
        np.uint8,
    )
    data = [colours[materials] for _, materials, _ in slabs(min(n_z, rows), rows)]
    start = time.perf_counter()
    with PngSliceWriter(folder / "slices", grid) as writer:
        for z0 in range(0, n_z, rows):
            writer.write_slab(data[0][: n_z - z0])
    seconds = time.perf_counter() - start
    return {"slices": n_z, "seconds": round(seconds, 2), "slices_per_s": round(n_z / seconds, 1)}


def vdb_material(n_z: int, rows: int, folder: Path) -> dict[str, object]:
    grid = GridSpec((0.0, 0.0, 0.0), load_profile("j750").voxel_mm, (n_z, N_Y, N_X))
    data = list(slabs(n_z, rows))
    result: dict[str, object] = {"slices": n_z}
    for with_material in (False, True):
        writer = VdbStackWriter(
            grid, sdf_half_width_mm=0.1, spool_dir=folder, material_grid=with_material
        )
        start = time.perf_counter()
        for z0, materials, layers in data:
            sdf = np.where(layers == 1, -0.05, np.where(layers > 0, -0.1, 0.1)).astype(np.float32)
            rgb = np.zeros((*layers.shape, 3), np.uint8)
            writer.write_slab(
                z0, layers, rgb, layers == 1, sdf, materials=materials if with_material else None
            )
        writer.write(folder / "v.vdb")
        key = "seconds_with_material" if with_material else "seconds_without_material"
        result[key] = round(time.perf_counter() - start, 2)
    return result


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per writer: milliseconds and kilobytes per slice."""
    one = details["one_slice"]
    rows: list[dict[str, Any]] = [
        {"case": "encode_png, one slice", "slices": 1, "ms_per_slice": one["encode_png_ms"],
         "kb_per_slice": one["encode_png_kb"]},
        {"case": "Pillow level 1, one slice", "slices": 1,
         "ms_per_slice": one["pillow_level1_ms"], "kb_per_slice": one["pillow_level1_kb"]},
    ]  # fmt: skip
    taller = {**details["gcvf_4x_taller"], "label": ", 4x taller"}
    for run in [*details["gcvf"], taller]:
        rows.append(
            {
                "case": f"GcvfWriter, {run['threads']} thread{'s' * (run['threads'] > 1)}"
                + run.get("label", ""),
                "slices": run["slices"],
                "ms_per_slice": round(1e3 * run["seconds"] / run["slices"], 1),
                "kb_per_slice": round(run["bytes_per_slice"] / 1e3),
                "peak_traced_mb": run["peak_traced_mb_above_input"],
            }
        )
    png = details["png_folder"]
    rows.append(
        {
            "case": "PngSliceWriter",
            "slices": png["slices"],
            "ms_per_slice": round(1e3 * png["seconds"] / png["slices"], 1),
        }
    )
    vdb = details["vdb_material_grid"]
    for key, label in (("seconds_without_material", "without"), ("seconds_with_material", "with")):
        rows.append(
            {
                "case": f"VdbStackWriter, {label} the material grid",
                "slices": vdb["slices"],
                "ms_per_slice": round(1e3 * vdb[key] / vdb["slices"], 1),
            }
        )
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--slices", type=int, default=96)
    parsed.add_argument("--slab", type=int, default=24, help="z rows per slab")
    args = parsed.parse_args()
    if args.quick:
        args.slices, args.slab = 8, 4
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        result = {
            "one_slice": one_slice(),
            "gcvf": [gcvf(args.slices, args.slab, threads, folder) for threads in (1, 2)],
            "gcvf_4x_taller": gcvf(4 * args.slices, args.slab, 2, folder),
            "png_folder": png_folder(args.slices, args.slab, folder),
            "vdb_material_grid": vdb_material(args.slices // 2, args.slab, folder),
        }
    print(json.dumps(result, indent=1))
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(result), "details": result}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
