"""Robust and paper offset shells: quality on the issue's inputs, and the robust method's
speed against OpenVDB on ~100k faces.

    python benchmarks/bench_offset.py [--part quality|speed|flat ...] [--size-mm 50]
        [--voxel-mm 0.05]

quality: for an icosphere (r 10 mm, 2562 vertices), a 10 x 20 x 30 mm box and, from the
shared meshes, the bunny at 50 mm, spot at 100 mm, the duck at 50 mm and the airplane at
100 mm, two layers of 0.5 and 1.0 mm (depths 0.5 and 1.5 mm) with the robust and the paper
method: time, closed, oriented, self-intersections, nested, equidistance p50/p99/max (% of
D_k), the region and place of the largest error, per region p99, input self-intersections.

speed: spot (5856 faces) with two Loop subdivisions (93,696 faces) scaled to --size-mm;
for each depth the robust offset is timed (one layer) next to OpenVDB's
createLevelSetFromPolygons at --voxel-mm with a narrow band just wide enough to hold that
depth (in Debian's python3, the same session), as a ratio.

flat: the default model (data/colour_target, 3468 faces, 2364 of them in 174 flat
patches) and the airplane at 100 mm, two layers of 0.5 mm, with one prism per flat patch
(shellvox.offset.reference.planar) and, in the same process, with per-face prisms only: time, CPU
time, pieces, shell faces and volumes (which must agree).

Running some parts keeps the others' results from the current result file.
"""

from __future__ import annotations

import resource
import time
import warnings
from typing import Any

import numpy as np
import trimesh
from _common import (
    DEFAULT_MODEL,
    load_average,
    load_shared,
    mesh_path,
    parser,
    previous_details,
    write_result,
)

import shellvox.offset.reference.band as band
from shellvox.offset import offset_shells, shell_report
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.robust import ShellDefectWarning
from shellvox.testing import level_set_seconds

NAME = "bench_offset"
WHAT = (
    "The robust offset shells' time against OpenVDB's mesh-to-level-set with a band "
    "holding the same depth (spot, 93,696 faces), and the robust and paper methods' "
    "validity and depth error on the issue's inputs (layers 0.5 + 1.0 mm)."
)
PARTS = ("quality", "speed", "flat")
REAL = {
    "bunny_50mm": ("bunny", 50.0),
    "spot_100mm": ("spot", 100.0),
    "duck_50mm": ("duck", 50.0),
    "airplane_100mm": ("airplane", 100.0),
}
THICKNESS = [0.5, 1.0]  # depths 0.5 and 1.5 mm


def inputs(quick: bool) -> dict[str, trimesh.Trimesh]:
    """Return the six done-criteria inputs (``quick``: the two made here, smaller)."""
    meshes = {
        "icosphere_r10": trimesh.creation.icosphere(subdivisions=1 if quick else 4, radius=10.0),
        "box_10x20x30": trimesh.creation.box((10.0, 20.0, 30.0)),
    }
    if not quick:
        for name, (shared, size) in REAL.items():
            meshes[name] = load_shared(shared, size)
    return meshes


def quality_row(mesh: trimesh.Trimesh, method: str) -> dict[str, Any]:
    """Offset `mesh` with `method` and summarise :func:`shellvox.offset.shell_report` per layer."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shells = offset_shells(v, f, THICKNESS, method=method)  # type: ignore[arg-type]
    seconds = time.perf_counter() - start
    report = shell_report(v, f, THICKNESS, shells, baselines=False, n_samples=20_000)
    layers = []
    for layer in report["layers"]:
        shell = layer["shell"]
        eq = shell["equidistance"] or {}
        layers.append(
            {
                "depth_mm": layer["depth_mm"]["max"],
                "n_faces": shell["n_faces"],
                "closed": shell["closed"],
                "oriented": shell["oriented"],
                "self_intersections": shell["self_intersections"],
                "nested": shell["nested"],
                "error_pct": eq.get("error_pct"),
                "p99_by_region": {k: r["p99"] for k, r in eq.get("by_region", {}).items()},
                "share_by_region": {k: r["share"] for k, r in eq.get("by_region", {}).items()},
                "worst": eq.get("worst"),
            }
        )
    return {
        "method": method,
        "n_faces": len(f),
        "input_self_intersections": report["input_self_intersections"],
        "time_s": seconds,
        "warnings": [str(w.message) for w in caught],
        "layers": layers,
    }


def quality(names: list[str] | None, quick: bool) -> dict[str, Any]:
    """Return quality rows for every input and method, printing a table as they come."""
    rows: dict[str, Any] = {}
    print(
        f"{'mesh':>15} {'method':>6} {'D':>4} {'closed':>6} {'orient':>6} {'SI':>4} "
        f"{'nested':>6} {'p50%':>8} {'p99%':>8} {'max%':>8} {'worst at':>12} {'time_s':>7}"
    )
    for name, mesh in inputs(quick).items():
        if names and name not in names:
            continue
        for method in ("robust", "paper"):
            row = quality_row(mesh, method)
            rows.setdefault(name, {})[method] = row
            for layer in row["layers"]:
                err = layer["error_pct"] or {
                    "p50": float("nan"),
                    "p99": float("nan"),
                    "max": float("nan"),
                }
                where = (layer["worst"] or {}).get("region", "-")
                print(
                    f"{name:>15} {method:>6} {layer['depth_mm']:4.1f} {layer['closed']!s:>6} "
                    f"{layer['oriented']!s:>6} {layer['self_intersections']:4d} "
                    f"{layer['nested']!s:>6} {err['p50']:8.4f} {err['p99']:8.4f} "
                    f"{err['max']:8.3f} {where:>12} {row['time_s']:7.1f}",
                    flush=True,
                )
    return rows


def speed(
    size_mm: float, voxel_mm: float, depths: list[float], subdivisions: int, quick: bool
) -> dict[str, Any]:
    """Time the robust offset (one layer per depth) against OpenVDB's mesh-to-level-set."""
    if quick:  # a small sphere: the robust offset takes minutes on spot
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=size_mm / 2)
    else:
        mesh = load_shared("spot", size_mm, subdivisions)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    label = "icosphere (quick)" if quick else f"spot, Loop x{subdivisions}"
    print(f"mesh: {label}, {len(faces)} faces, {size_mm} mm, voxel {voxel_mm} mm")
    print(f"{'depth_mm':>9} {'robust_s':>9} {'openvdb_s':>10} {'ratio':>7} {'shell_faces':>12}")
    runs = []
    for depth in depths:
        load_before = load_average()
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            (shell,) = offset_shells(vertices, faces, [depth], method="robust")
        robust_s = time.perf_counter() - start
        defects = [str(w.message) for w in caught if issubclass(w.category, ShellDefectWarning)]
        shell_mesh = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
        valid = {
            "closed": bool(shell_mesh.is_watertight),
            "oriented": bool(shell_mesh.is_winding_consistent),
            "self_intersections": len(intersecting_pairs(shell.vertices, shell.faces)),
            "defect_warnings": defects,
            "peak_rss_gb_so_far": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        }
        half_width = float(np.ceil(depth / voxel_mm) + 2)
        vdb = level_set_seconds(vertices, faces, voxel_mm, half_width)
        vdb_s = vdb["seconds"]
        print(
            f"{depth:9.2f} {robust_s:9.2f} {vdb_s:10.2f} {robust_s / vdb_s:7.2f} "
            f"{len(shell.faces):12d}   (vdb active voxels {vdb['active_voxels']}) {valid}",
            flush=True,
        )
        runs.append(
            {
                "depth_mm": depth,
                "robust_s": robust_s,
                "openvdb_s": vdb_s,
                "ratio": robust_s / vdb_s,
                "shell_faces": len(shell.faces),
                "openvdb_active_voxels": vdb["active_voxels"],
                "load_avg_1_5_15_before": load_before,
                "load_avg_1_5_15_after": load_average(),
                **valid,
            }
        )
    return {
        "mesh": label,
        "n_faces": len(faces),
        "size_mm": size_mm,
        "voxel_mm": voxel_mm,
        "runs": runs,
    }


def flat(quick: bool) -> dict[str, Any]:
    """Time the robust shells with and without one prism per flat patch."""
    cases = {"colour_target": (DEFAULT_MODEL, None)}
    if not quick:
        cases["airplane_100mm"] = (mesh_path("airplane"), 100.0)
    keep = band.flat_patches
    rows: dict[str, Any] = {}
    for name, (path, size) in cases.items():
        raw = trimesh.load(path, force="mesh")
        mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
        mesh.merge_vertices(merge_tex=True, merge_norm=True)
        if size is not None:
            mesh.apply_scale(size / mesh.extents.max())
        v = np.asarray(mesh.vertices, dtype=np.float64)
        f = np.asarray(mesh.faces, dtype=np.int64)
        for mode in ("patches", "per_face"):
            if mode == "per_face":
                band.flat_patches = lambda pairs, n, d: (np.full(n, -1), 0)
            try:
                pieces = band.layer_pieces(band.features(v, f), np.full(len(f), 0.5))
                load = load_average()
                start, cpu = time.perf_counter(), time.process_time()
                shells = offset_shells(v, f, [0.5, 0.5], method="robust")
                row = {
                    "seconds": time.perf_counter() - start,
                    "cpu_seconds": time.process_time() - cpu,
                    "load_avg_1_5_15_before": load,
                    "pieces_layer_1": int(sum(len(p) for p, _ in pieces)),
                    "shell_faces": [len(s.faces) for s in shells],
                    "volumes_mm3": [
                        float(trimesh.Trimesh(s.vertices, s.faces, process=False).volume)
                        for s in shells
                    ],
                }
            finally:
                band.flat_patches = keep
            rows.setdefault(name, {"n_faces": len(f)})[mode] = row
            print(
                name,
                mode,
                {k: row[k] for k in ("seconds", "pieces_layer_1", "shell_faces")},
                flush=True,
            )
    return rows


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """Rows of the robust speed against OpenVDB, then of each input's quality per method."""
    rows: list[dict[str, Any]] = []
    speed_part = details.get("speed")
    if speed_part:
        for run in speed_part["runs"]:
            rows.append(
                {
                    "case": f"{speed_part['mesh']}, {speed_part['n_faces']:,} faces, "
                    f"{speed_part['size_mm']:g} mm, depth {run['depth_mm']:g} mm",
                    "method": "robust",
                    "faces": speed_part["n_faces"],
                    "seconds": round(run["robust_s"], 1),
                    "openvdb_s": round(run["openvdb_s"], 1),
                    "ratio": round(run["ratio"], 2),
                    "closed": run["closed"] and run["oriented"],
                    "self_intersections": run["self_intersections"],
                }
            )
    for name, methods in details.get("quality", {}).items():
        for method, row in methods.items():
            errors = [layer["error_pct"] for layer in row["layers"] if layer["error_pct"]]
            rows.append(
                {
                    "case": name,
                    "method": method,
                    "faces": row["n_faces"],
                    "seconds": round(row["time_s"], 2),
                    "closed": all(x["closed"] and x["oriented"] for x in row["layers"]),
                    "self_intersections": sum(x["self_intersections"] for x in row["layers"]),
                    "p99_error_pct": round(max(e["p99"] for e in errors), 3) if errors else None,
                }
            )
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--part", action="append", choices=PARTS, help="default: all")
    parsed.add_argument("--meshes", type=str, default="", help="comma list (quality part)")
    parsed.add_argument("--size-mm", type=float, default=50.0)
    parsed.add_argument("--voxel-mm", type=float, default=0.05)
    parsed.add_argument("--depths", type=str, default="0.5,1.0,1.5")
    parsed.add_argument("--subdivisions", type=int, default=2, help="Loop subdivisions")
    args = parsed.parse_args()
    parts = args.part or list(PARTS)
    details = previous_details(NAME, quick=args.quick) if args.part or args.meshes else {}
    details.pop("run", None)
    if "quality" in parts:
        names = [n for n in args.meshes.split(",") if n] or None
        rows = quality(names, args.quick)
        details["quality"] = {**details.get("quality", {}), **rows} if names else rows
        details["quality_setup"] = {"thickness_mm": THICKNESS, "n_samples": 20_000}
    if "flat" in parts:
        details["flat"] = flat(args.quick)
    if "speed" in parts:
        depths = [float(x) for x in args.depths.split(",")]
        if args.quick:
            depths = [0.5]
        details["speed"] = speed(args.size_mm, args.voxel_mm, depths, args.subdivisions, args.quick)
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
