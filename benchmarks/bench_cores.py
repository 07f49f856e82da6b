"""How much two processes get done at once on this machine, against one alone.

Usage: .venv/bin/python benchmarks/bench_cores.py [--size-mm 35]
       [--out benchmarks/results/bench_cores.json]

Slab parallelism can scale no better than the machine does. Three probes, each run by
one process alone and then by two processes at once (forked, started together), report
the time of one run alone, the mean time of a run with two at once, and the throughput
ratio ``2 * alone / together`` (2.0 is perfect scaling):

- ``arithmetic``: a compiled loop on registers (no memory traffic);
- ``memory``: a compiled pass over 512 MB (streaming reads and writes);
- ``slab``: :func:`shellvox.voxel.slab.compute_slab` on the same 24 rows of spot on the J750 grid
  (the build's own per-slab work; the model is built before the fork).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPOT = ROOT.parent / "shared" / "meshes" / "spot" / "spot_triangulated.obj"


@numba.njit(cache=True)
def _arithmetic(n: int) -> float:
    x = 0.0
    for i in range(n):
        x = x * 0.999999 + (i & 7) * 1e-3
    return x


@numba.njit(cache=True)
def _memory(a: np.ndarray, b: np.ndarray, repeats: int) -> float:
    for _ in range(repeats):
        for i in range(a.size):
            b[i] = a[i] * 1.0001 + 1.0
    return float(b[0])


def _timed(work: Callable[[], object], queue: Any) -> None:
    start = time.perf_counter()
    work()
    queue.put(time.perf_counter() - start)


def _probe(work: Callable[[], object]) -> dict[str, float]:
    work()  # warm (compile, caches)
    context = get_context("fork")
    results = {}
    for n in (1, 2):
        queue = context.SimpleQueue()
        procs = [context.Process(target=_timed, args=(work, queue)) for _ in range(n)]
        for proc in procs:
            proc.start()
        for proc in procs:
            proc.join()
        results[n] = float(np.mean([queue.get() for _ in range(n)]))
    return {
        "alone_s": results[1],
        "two_at_once_s": results[2],
        "throughput_ratio": 2 * results[1] / results[2],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size-mm", type=float, default=35.0)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/bench_cores.json")
    args = parser.parse_args()
    record: dict[str, Any] = {"cpus": len(os.sched_getaffinity(0)), "load_before": os.getloadavg()}
    record["arithmetic"] = _probe(lambda: _arithmetic(400_000_000))
    a = np.ones(2**26)
    b = np.empty_like(a)
    record["memory"] = _probe(lambda: _memory(a, b, 6))
    if SPOT.is_file():
        from shellvox.config import BuildConfig, LoadOptions
        from shellvox.loading import load_model
        from shellvox.printer import load_profile
        from shellvox.stack import grid_for
        from shellvox.voxel.geometry import SurfaceIndex
        from shellvox.voxel.slab import StackModel, compute_slab

        mesh = load_model(SPOT, LoadOptions(scale=args.size_mm / 1.75))
        profile = load_profile("j750")
        config = BuildConfig(voxel_mm=profile.voxel_mm, thickness_mm=(0.5, 0.5))
        grid = grid_for(mesh, config)
        depth = np.cumsum(np.full((2, mesh.n_faces), 0.5), axis=0)
        model = StackModel(
            surfaces=((mesh.vertices, mesh.faces),),
            surface=SurfaceIndex.build(mesh.vertices, mesh.faces),
            colour_at=mesh.colour_at, surface_colour=mesh.surface_colour(),
            colour_layers=(1,), sdf_half_width_mm=config.sdf_half_width_mm,
            depth_mm=depth, layer_rule="distance",
        )  # fmt: skip
        _ = model.surface.regions
        middle = grid.shape_zyx[0] // 2
        record["slab"] = _probe(lambda: compute_slab(model, grid, middle, middle + 24))
        record["slab"]["grid_zyx"] = list(grid.shape_zyx)
    record["load_after"] = os.getloadavg()
    args.out.write_text(json.dumps(record, indent=2) + "\n")
    print(json.dumps(record, indent=2))


if __name__ == "__main__":
    main()
