"""Latency of ``shellvox view`` on a large build: time to first slice, per-slice latency.

    python benchmarks/bench_viewer.py [BUILD] [--screen 1600x1000] [--source auto|tiff|zarr]

Without BUILD, spot at 100 mm is built first on the J750 grid with the default formats
(5.8 G voxels; a few minutes). There is no external peer: the latencies are absolute
(the page asks again after 0.1 s of scrolling).

The server runs in this process (a thread), and the requests are the page's own: for
a screen of W x H device pixels, the slice fitted to the screen (every ``step``-th voxel,
``step`` the power of two nearest the voxels per pixel), each mode's arrays asked for at
once (colour: layers + colour; depth: layers + depth; ...), timed until the last byte.

- ``first_slice``: from opening the folder (manifest, file sizes, page index of each
  stack) to the first z slice in colour mode, as ``shellvox view`` starts.
- ``--source``: the TIFF stacks or the OME-Zarr store (``auto``: the store when the build
  has one, as ``shellvox view`` does).
- ``cold``: each axis and mode in turn on a server that decodes pages only when asked
  (the first y or x slice through a stack decodes its pages; the next ones read them
  from the cache).
- ``warmed``: after the server's background decoding of the whole-model pages
  (``BuildFolder.warm_in_background``, timed), every axis and mode at several slices.
- ``zoomed``: one voxel per pixel around the model's centre (a page range at step 1).
  ``warmed`` and ``zoomed`` run while the server's overview pass (the opening slices and
  the surface's colours, one pass over the pages) may still be reading.
- ``settled``: the same once that pass has ended, and eight consecutive colour slices on
  each axis (a scroll).
"""

from __future__ import annotations

import http.client
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from _common import mesh_path, parser, scale_for, write_result

from shellvox.output import file_summary
from shellvox.viewer import BuildFolder, ViewerServer

NAME = "bench_viewer"
WHAT = (
    "Latency of shellvox view on a large build (spot at 100 mm, 5.8 G voxels): "
    "opening, and every axis and mode of slices fitted to a 1600 x 1000 screen, cold, "
    "warmed, zoomed to one voxel per pixel and once the opening pass has ended."
)

MODES = {
    "colour": ("layers", "colour"),
    "layers": ("layers",),
    "blend": ("layers", "colour"),
    "materials": ("materials",),
    "depth": ("layers", "depth"),
    "thickness": ("layers", "depth"),
}
PLANE = {"z": ("y", "x"), "y": ("z", "x"), "x": ("z", "y")}


def fitted_region(folder: BuildFolder, axis: str, width: int, height: int) -> dict[str, int]:
    """The region the page asks for when the whole slice fits the screen (viewer.js)."""
    v_axis, u_axis = PLANE[axis]
    shape = dict(zip("zyx", folder.grid.shape_zyx, strict=True))
    size = dict(zip("xyz", folder.grid.voxel_mm, strict=True))
    scale = 0.95 * min(
        width / (shape[u_axis] * size[u_axis]), height / (shape[v_axis] * size[v_axis])
    )

    def step(voxel_mm: float) -> int:
        return int(2 ** max(0, round(math.log2(1 / (scale * voxel_mm)))))

    return {"r0": 0, "r1": shape[v_axis], "rs": step(size[v_axis]),
            "c0": 0, "c1": shape[u_axis], "cs": step(size[u_axis])}  # fmt: skip


def zoomed_region(folder: BuildFolder, axis: str, width: int, height: int) -> dict[str, int]:
    """One voxel per pixel, ``width x height`` voxels around the slice's centre."""
    v_axis, u_axis = PLANE[axis]
    shape = dict(zip("zyx", folder.grid.shape_zyx, strict=True))
    r0 = max(0, shape[v_axis] // 2 - height // 2)
    c0 = max(0, shape[u_axis] // 2 - width // 2)
    return {"r0": r0, "r1": r0 + height, "rs": 1, "c0": c0, "c1": c0 + width, "cs": 1}


def fetch(port: int, kind: str, axis: str, index: int, region: dict[str, int]) -> int:
    """GET one slice array; return its size in bytes."""
    query = "&".join(f"{k}={v}" for k, v in {"kind": kind, "axis": axis, "index": index,
                                              **region}.items())  # fmt: skip
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    connection.request("GET", "/api/slice?" + query)
    response = connection.getresponse()
    body = response.read()
    connection.close()
    if response.status != 200:
        raise RuntimeError(f"{query}: {response.status} {body[:200]!r}")
    return len(body)


def view(pool: ThreadPoolExecutor, port: int, mode: str, axis: str, index: int,
         region: dict[str, int]) -> float:  # fmt: skip
    """Seconds until all of a mode's arrays arrived (asked for at once, as the page does)."""
    started = time.perf_counter()
    futures = [pool.submit(fetch, port, kind, axis, index, region) for kind in MODES[mode]]
    for future in futures:
        future.result()
    return time.perf_counter() - started


def _cache_mb(folder: BuildFolder) -> float | None:
    """Megabytes in the TIFF stacks' page cache (None for the store: TensorStore's own)."""
    cache = getattr(folder.stacks["layers"], "cache", None)
    return None if cache is None else round(cache.used_bytes / 1e6, 1)


def serve(folder: BuildFolder, *, warm: bool) -> tuple[ViewerServer, threading.Thread]:
    server = ViewerServer(folder, 0, warm=warm)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    return server, thread


def build(out: Path, quick: bool) -> str:
    """Build spot at 100 mm on the J750 grid (quick: the default model, coarse) into `out`."""
    if quick:
        model, options = mesh_path("default"), ["--voxel-size", "0.1,0.1,0.1"]
        what = "the default model at 0.1 mm voxels, default formats"
    else:
        model, options = mesh_path("spot"), ["--scale", repr(scale_for("spot", 100.0))]
        what = "spot at 100 mm on the J750 grid, default formats"
    command = [sys.executable, "-m", "shellvox.cli", "build", str(model), "-o", str(out),
               "--printer", "j750", "--no-progress", *options]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True)
    return what


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per phase and axis: the slowest slice (every mode) and its mode."""

    def worst(seconds: dict[str, Any], key: str | None) -> tuple[float, str]:
        pairs = []
        for mode, value in seconds.items():
            if isinstance(value, list):
                pairs.append((max(value), mode))
            else:
                pairs.append((value[key] if key else max(value.values()), mode))
        return max(pairs)

    first = details["first_slice"]
    rows: list[dict[str, Any]] = [
        {"phase": "open + first slice", "axis": "z", "max_s": first["total_seconds"],
         "slowest_mode": "colour"},
    ]  # fmt: skip
    for phase, key in (("cold", None), ("warmed", "max"), ("zoomed", "first"), ("settled", "max")):
        if phase not in details:
            continue
        for axis, seconds in details[phase]["seconds"].items():
            value, mode = worst(seconds, key)
            rows.append({"phase": phase, "axis": axis, "max_s": value, "slowest_mode": mode})
    for axis, scroll in details.get("settled", {}).get("scroll_colour", {}).items():
        rows.append(
            {"phase": "scroll (next slices)", "axis": axis, "max_s": scroll["max_next"],
             "slowest_mode": "colour"}
        )  # fmt: skip
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("build", nargs="?", type=Path, help="a finished build's folder")
    parsed.add_argument("--screen", default="1600x1000", help="device pixels W x H")
    parsed.add_argument("--source", choices=("auto", "tiff", "zarr"), default="auto")
    args = parsed.parse_args()
    if args.build is not None:
        result = measure(args.build, args, str(args.build))
    else:
        with tempfile.TemporaryDirectory() as folder:
            made = build(Path(folder) / "build", args.quick)
            result = measure(Path(folder) / "build", args, made)
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(result), "details": result}, quick=args.quick
    )
    print(f"wrote {path}")


def measure(build_folder: Path, args: Any, described: str) -> dict[str, Any]:
    """Serve `build_folder` in this process and time the page's requests."""
    width, height = (int(v) for v in args.screen.split("x"))
    load = os.getloadavg()
    pool = ThreadPoolExecutor(4)
    result: dict[str, Any] = {
        "screen": args.screen,
        "source": args.source,
        "load_average_at_start": [round(v, 2) for v in load],
    }

    # time to first slice, as `shellvox view` starts: open, index the stacks, z in colour
    started = time.perf_counter()
    folder = BuildFolder.open(build_folder, source=args.source)
    opened = time.perf_counter() - started
    server, thread = serve(folder, warm=False)
    n_z, n_y, n_x = folder.grid.shape_zyx
    region = fitted_region(folder, "z", width, height)
    first = view(pool, server.port, "colour", "z", n_z // 2, region)
    result["build"] = {
        "folder": described,
        "stacks": sorted({type(s).__name__ for s in folder.stacks.values()}),
        "grid_zyx": [n_z, n_y, n_x],
        "voxels": n_z * n_y * n_x,
        "file_bytes": {name: size for name, _, size in file_summary(folder.manifest["files"])},
    }
    result["first_slice"] = {
        "open_seconds": round(opened, 3),
        "first_z_slice_seconds": round(first, 3),
        "total_seconds": round(time.perf_counter() - started, 3),
    }
    print(json.dumps(result["first_slice"]), flush=True)

    # cold: pages decoded when first asked for
    cold: dict[str, dict[str, list[float]]] = {}
    for mode in MODES:
        for axis in ("z", "y", "x"):
            extent = {"z": n_z, "y": n_y, "x": n_x}[axis]
            region = fitted_region(folder, axis, width, height)
            times = [view(pool, server.port, mode, axis, extent // 2 + k * 11, region)
                     for k in range(3)]  # fmt: skip
            cold.setdefault(axis, {})[mode] = [round(t, 3) for t in times]
            print("cold", axis, mode, cold[axis][mode], flush=True)
    result["cold"] = {
        "note": "three slices per axis and mode, modes in this order; the first y slice "
        "of a mode whose stack was not read yet decodes the pages, the rest read them "
        "from the cache",
        "seconds": cold,
        "steps": {a: fitted_region(folder, a, width, height) for a in "zyx"},
        "cache_mb": _cache_mb(folder),
    }
    server.shutdown()
    server.server_close()
    thread.join()

    # warmed: the server decodes the whole-model pages first (as `shellvox view` does)
    folder = BuildFolder.open(build_folder, source=args.source)
    started = time.perf_counter()
    server, thread = serve(folder, warm=True)
    assert folder._warming is not None
    folder._warming.join()
    warming = time.perf_counter() - started
    warmed: dict[str, dict[str, dict[str, float]]] = {}
    for axis in ("z", "y", "x"):
        extent = {"z": n_z, "y": n_y, "x": n_x}[axis]
        region = fitted_region(folder, axis, width, height)
        for mode in MODES:
            times = [view(pool, server.port, mode, axis, int(extent * f), region)
                     for f in (0.3, 0.4, 0.5, 0.6, 0.7)]  # fmt: skip
            warmed.setdefault(axis, {})[mode] = {
                "median": round(statistics.median(times), 3),
                "max": round(max(times), 3),
            }
            print("warmed", axis, mode, warmed[axis][mode], flush=True)
    result["warmed"] = {
        "background_decoding_seconds": round(warming, 2),
        "cache_mb": _cache_mb(folder),
        "seconds": warmed,
    }
    zoomed: dict[str, dict[str, float]] = {}
    for axis in ("y", "x"):
        extent = {"z": n_z, "y": n_y, "x": n_x}[axis]
        region = zoomed_region(folder, axis, width, height)
        for mode in ("colour", "materials", "depth"):
            first_time = view(pool, server.port, mode, axis, extent // 2 + 3, region)
            again = view(pool, server.port, mode, axis, extent // 2 + 5, region)
            zoomed.setdefault(axis, {})[mode] = {"first": round(first_time, 3),
                                                 "next": round(again, 3)}  # fmt: skip
            print("zoomed", axis, mode, zoomed[axis][mode], flush=True)
    result["zoomed"] = {
        "note": f"{width} x {height} voxels at step 1 around the centre: pages not among "
        "the warmed ones are decoded on the first slice",
        "seconds": zoomed,
    }

    # settled: once the overview pass (opening slices, surface colours) has ended
    overview_done = server.overview.done.wait(600)
    overview_seconds = time.perf_counter() - started
    settled: dict[str, dict[str, dict[str, float]]] = {}
    scroll: dict[str, dict[str, float]] = {}
    for axis in ("z", "y", "x"):
        extent = {"z": n_z, "y": n_y, "x": n_x}[axis]
        region = fitted_region(folder, axis, width, height)
        for mode in MODES:
            times = [view(pool, server.port, mode, axis, int(extent * f), region)
                     for f in (0.35, 0.45, 0.55, 0.65)]  # fmt: skip
            settled.setdefault(axis, {})[mode] = {
                "median": round(statistics.median(times), 3),
                "max": round(max(times), 3),
            }
            print("settled", axis, mode, settled[axis][mode], flush=True)
        at = int(extent * 0.42)  # the next slices one by one, as a scroll wheel asks
        times = [view(pool, server.port, "colour", axis, at + k, region) for k in range(1, 9)]
        scroll[axis] = {"first": round(times[0], 3), "median_next": round(
            statistics.median(times[1:]), 3), "max_next": round(max(times[1:]), 3)}  # fmt: skip
        print("scroll", axis, scroll[axis], flush=True)
    result["settled"] = {
        "note": "after the overview pass (opening slices and surface colours) ended, "
        "seconds after the server started; four slices per axis and mode, and in colour "
        "mode eight consecutive slices from 0.42 of the axis",
        "overview_done": overview_done,
        "overview_seconds": round(overview_seconds, 1),
        "seconds": settled,
        "scroll_colour": scroll,
    }
    server.shutdown()
    server.server_close()
    thread.join()
    pool.shutdown()
    return result


if __name__ == "__main__":
    main()
