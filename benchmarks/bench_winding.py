"""The fast generalised winding number (compiled tree) against libigl's, on the same points.

    python benchmarks/bench_winding.py [--quick]

Meshes: spot (5,856 faces, closed), spot Loop-subdivided twice (93,696 faces) and the Utah
teapot (992 faces, open: no bottom, a separate lid, the spout and handle through the
body), each with 1,000,000 query points in its bounding box grown by 5 % a side, two
ways: uniform random points, and the centres of a 100 x 100 x 100 grid (the voxel build's
queries). For each: the time of shellvox's
:func:`shellvox.voxel.geometry.fast_winding_numbers` (tree build included, default threads,
``beta = 2``) against libigl's ``fast_winding_number`` on triangles (its tree build
included, its own threads, the same method at order 2 and ``beta = 2``), best of two runs
interleaved, as wall and process CPU time (the machine may be shared: the ratios in the
same run are the measure, and the load average is recorded); their agreement (the share
of points with the same inside decision ``w >= 1/2``, the largest and 99th percentile
``|w_ours - w_libigl|``); and the error of each against the exact winding number
(libigl's ``winding_number``) on 2,000 of the points. ``--quick``: 20,000 points, spot
and the teapot only.
"""

from __future__ import annotations

import time
from typing import Any

import igl
import numpy as np
import trimesh
from _common import MESHES, load_average, load_shared, parser, write_result

from shellvox.voxel.geometry import WindingTree, fast_winding_numbers

NAME = "bench_winding"
WHAT = (
    "Time and agreement of shellvox's compiled fast winding number (Barill et al.'s tree, "
    "beta = 2) against libigl's fast_winding_number on the same 1 M points (random in the "
    "box, and a 100^3 grid) of spot, spot subdivided (93,696 faces) and the open teapot."
)
TEAPOT = MESHES / "teapot" / "teapot.obj"
#: Points compared with the exact winding number.
EXACT_SAMPLE = 2000


def meshes(quick: bool) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The meshes by name: vertices ``(V, 3)`` mm and faces ``(F, 3)``."""
    found: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    spot = load_shared("spot", 30.0)
    found["spot"] = (np.asarray(spot.vertices), np.asarray(spot.faces, np.int64))
    if not quick:
        fine = load_shared("spot", 30.0, subdivisions=2)
        found["spot_subdivided"] = (np.asarray(fine.vertices), np.asarray(fine.faces, np.int64))
    if not TEAPOT.is_file():
        raise SystemExit(f"{TEAPOT} is missing: the benchmarks read $SHELLVOX_MESHES")
    teapot = trimesh.load(TEAPOT, force="mesh")
    found["teapot"] = (np.asarray(teapot.vertices), np.asarray(teapot.faces, np.int64))
    return found


def query_points(vertices: np.ndarray, n_points: int, kind: str) -> np.ndarray:
    """`n_points` points in the box of `vertices` grown by 5 % a side: random or a grid."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    low, high = low - 0.05 * (high - low), high + 0.05 * (high - low)
    if kind == "random":
        return np.random.default_rng(0).uniform(low, high, (n_points, 3))
    side = round(n_points ** (1 / 3))
    axes = [low[k] + (np.arange(side) + 0.5) * (high[k] - low[k]) / side for k in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def compare(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> dict[str, Any]:
    """Time both on `points` (best of two, interleaved) and compare their answers."""
    ours_s, igl_s, build_s, ours_cpu, igl_cpu = [], [], [], [], []
    for _ in range(2):
        start, cpu = time.perf_counter(), time.process_time()
        tree = WindingTree.build(vertices, faces)
        build_s.append(time.perf_counter() - start)
        ours = tree.evaluate(points)
        ours_s.append(time.perf_counter() - start)
        ours_cpu.append(time.process_time() - cpu)
        start, cpu = time.perf_counter(), time.process_time()
        theirs = np.asarray(igl.fast_winding_number(vertices, faces, points))
        igl_s.append(time.perf_counter() - start)
        igl_cpu.append(time.process_time() - cpu)
    difference = np.abs(ours - theirs)
    sample = np.random.default_rng(1).choice(len(points), EXACT_SAMPLE, replace=False)
    exact = np.asarray(igl.winding_number(vertices, faces, points[sample]))
    return {
        "n_points": len(points),
        "ours_s": round(min(ours_s), 3),
        "ours_tree_build_s": round(min(build_s), 4),
        "libigl_s": round(min(igl_s), 3),
        "ours_over_libigl": round(min(ours_s) / min(igl_s), 3),
        "ours_cpu_s": round(min(ours_cpu), 3),
        "libigl_cpu_s": round(min(igl_cpu), 3),
        "ours_over_libigl_cpu": round(min(ours_cpu) / min(igl_cpu), 3),
        "same_decision_share": float(np.mean((ours >= 0.5) == (theirs >= 0.5))),
        "different_decisions": int(np.count_nonzero((ours >= 0.5) != (theirs >= 0.5))),
        "max_abs_difference": float(difference.max()),
        "p99_abs_difference": float(np.quantile(difference, 0.99)),
        "ours_max_error_vs_exact": float(np.abs(ours[sample] - exact).max()),
        "libigl_max_error_vs_exact": float(np.abs(theirs[sample] - exact).max()),
        "all_runs_s": {
            "ours": ours_s,
            "libigl": igl_s,
            "ours_tree_build": build_s,
            "ours_cpu": ours_cpu,
            "libigl_cpu": igl_cpu,
        },
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for case, entry in details["cases"].items():
        rows.append({
            "case": case,
            "faces": entry["faces"],
            "points": entry["n_points"],
            "ours_s": entry["ours_s"],
            "ours tree build s": entry["ours_tree_build_s"],
            "libigl_s": entry["libigl_s"],
            "ours/libigl": entry["ours_over_libigl"],
            "ours/libigl cpu": entry["ours_over_libigl_cpu"],
            "same inside %": round(100 * entry["same_decision_share"], 4),
            "max |dw|": float(f"{entry['max_abs_difference']:.3g}"),
            "p99 |dw|": float(f"{entry['p99_abs_difference']:.3g}"),
            "ours max err": float(f"{entry['ours_max_error_vs_exact']:.3g}"),
            "libigl max err": float(f"{entry['libigl_max_error_vs_exact']:.3g}"),
        })  # fmt: skip
    return rows


def main() -> None:
    args = parser(__doc__).parse_args()
    n_points = 20_000 if args.quick else 1_000_000
    details: dict[str, Any] = {"load_average_1_5_15_min_at_start": load_average(), "cases": {}}
    tiny = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    start = time.perf_counter()
    fast_winding_numbers(tiny, np.array([[0, 1, 2]]), tiny)
    details["first_call_s_compile_or_cache_load"] = round(time.perf_counter() - start, 3)
    for name, (vertices, faces) in meshes(args.quick).items():
        for kind in ("random", "grid"):
            points = query_points(vertices, n_points, kind)
            entry = {"faces": len(faces), "points": kind, **compare(vertices, faces, points)}
            details["cases"][f"{name} {kind}"] = entry
            shown = {k: v for k, v in entry.items() if k != "all_runs_s"}
            print(f"{name} {kind}: {shown}", flush=True)
    details["load_average_1_5_15_min_at_end"] = load_average()
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
