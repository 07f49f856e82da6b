"""How much two processes get done at once on this machine, against one alone.

    python benchmarks/bench_cores.py [--size-mm 35]

Slab parallelism can scale no better than the machine does. Three probes, each run by
one process alone and then by two processes at once (forked, started together), report
the time of one run alone, the mean time of a run with two at once, and the throughput
ratio ``2 * alone / together`` (2.0 is perfect scaling; the peer is the probe alone):

- ``arithmetic``: a compiled loop on registers (no memory traffic);
- ``memory``: a compiled pass over 512 MB (streaming reads and writes);
- ``slab``: :func:`shellvox.voxel.slab.compute_slab` on the same 24 rows of spot on the J750 grid
  (the build's own per-slab work; the model is built before the fork).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from multiprocessing import get_context
from typing import Any

import numba
import numpy as np
from _common import load_average, parser, scaled_mesh, write_result

NAME = "bench_cores"
WHAT = (
    "Throughput of two processes at once against one alone on this machine "
    "(a compiled arithmetic loop, a 512 MB memory pass, and the build's own slab kernel)."
)


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


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    return [
        {
            "probe": probe,
            "alone_s": round(details[probe]["alone_s"], 3),
            "two_at_once_s": round(details[probe]["two_at_once_s"], 3),
            "throughput_ratio": round(details[probe]["throughput_ratio"], 3),
        }
        for probe in ("arithmetic", "memory", "slab")
        if probe in details
    ]


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--size-mm", type=float, default=35.0)
    args = parsed.parse_args()
    scale = 0.05 if args.quick else 1.0
    record: dict[str, Any] = {"cpus": len(os.sched_getaffinity(0)), "load_before": load_average()}
    record["arithmetic"] = _probe(lambda: _arithmetic(int(400_000_000 * scale)))
    a = np.ones(2**22 if args.quick else 2**26)
    b = np.empty_like(a)
    record["memory"] = _probe(lambda: _memory(a, b, 6))
    from shellvox import load_profile
    from shellvox.config import BuildConfig
    from shellvox.stack import grid_for
    from shellvox.voxel.geometry import SurfaceIndex
    from shellvox.voxel.slab import StackModel, compute_slab

    mesh = scaled_mesh("spot", 5.0 if args.quick else args.size_mm)
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
    record["slab"]["model"] = f"spot at {5.0 if args.quick else args.size_mm:g} mm, 24 rows"
    record["load_after"] = load_average()
    print(json.dumps(record, indent=2))
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(record), "details": record}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
