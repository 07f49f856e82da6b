"""Offset shells: quality on the issue's inputs, and speed against OpenVDB on ~100k faces.

Usage: .venv/bin/python benchmarks/bench_offset.py [--part quality|speed|both]
       [--size-mm 50] [--voxel-mm 0.05] [--out benchmarks/results/bench_offset.json]

quality: for an icosphere (r 10 mm, 2562 vertices), a 10 x 20 x 30 mm box and, from
../shared/meshes, the bunny at 50 mm, spot at 100 mm, the duck at 50 mm and the airplane at
100 mm, two layers of 0.5 and 1.0 mm (depths 0.5 and 1.5 mm) with the robust and the paper
method: time, closed, oriented, self-intersections, nested, equidistance p50/p99/max (% of
D_k), the region and place of the largest error, per region p99, input self-intersections.

speed: ../shared/meshes/spot (5856 faces) with two Loop subdivisions (93,696 faces) scaled
to --size-mm; for each depth the robust offset is timed (one layer) next to OpenVDB's
createLevelSetFromPolygons at --voxel-mm with a narrow band just wide enough to hold that
depth, as a ratio. A benchmark, not a test. Results are merged into --out (JSON).

flat: the default model (data/colour_target, 3468 faces, 2364 of them in 174 flat
patches) and the airplane at 100 mm, two layers of 0.5 mm, with one prism per flat patch
(shellvox.offset.planar) and, in the same process, with per-face prisms only: time, CPU time,
pieces, shell faces and volumes (which must agree).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

import shellvox.offset.band as band
from shellvox.offset import offset_shells, shell_report
from shellvox.offset.intersections import intersecting_pairs
from shellvox.offset.robust import ShellDefectWarning

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from openvdb_module import load_openvdb

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "meshes"
SPOT = SHARED / "spot" / "spot_triangulated.obj"
REAL = {
    "bunny_50mm": ("bunny/bunny.obj", 50.0),
    "spot_100mm": ("spot/spot_triangulated.obj", 100.0),
    "duck_50mm": ("duck/Duck.glb", 50.0),
    "airplane_100mm": ("airplane/colored_airplane.ply", 100.0),
}
THICKNESS = [0.5, 1.0]  # depths 0.5 and 1.5 mm


def load_shared(relative: str, size_mm: float, subdivisions: int = 0) -> trimesh.Trimesh:
    """Load a shared mesh merged by position, Loop-subdivided, largest extent `size_mm`."""
    raw = trimesh.load(SHARED / relative, force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    if subdivisions > 0:
        mesh = mesh.subdivide_loop(iterations=subdivisions)
    mesh.apply_scale(size_mm / mesh.extents.max())
    assert mesh.is_watertight and mesh.is_winding_consistent
    return mesh


def inputs() -> dict[str, trimesh.Trimesh]:
    """Return the six done-criteria inputs (the shared ones only when present)."""
    meshes = {
        "icosphere_r10": trimesh.creation.icosphere(subdivisions=4, radius=10.0),
        "box_10x20x30": trimesh.creation.box((10.0, 20.0, 30.0)),
    }
    for name, (relative, size) in REAL.items():
        if (SHARED / relative).is_file():
            meshes[name] = load_shared(relative, size)
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


def quality(names: list[str] | None) -> dict[str, Any]:
    """Return quality rows for every input and method, printing a table as they come."""
    rows: dict[str, Any] = {}
    print(
        f"{'mesh':>15} {'method':>6} {'D':>4} {'closed':>6} {'orient':>6} {'SI':>4} "
        f"{'nested':>6} {'p50%':>8} {'p99%':>8} {'max%':>8} {'worst at':>12} {'time_s':>7}"
    )
    for name, mesh in inputs().items():
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
    size_mm: float, voxel_mm: float, depths: list[float], subdivisions: int
) -> dict[str, Any]:
    """Time the robust offset (one layer per depth) against OpenVDB's mesh-to-level-set."""
    mesh = load_shared("spot/spot_triangulated.obj", size_mm, subdivisions)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    vdb = load_openvdb()
    transform = vdb.createLinearTransform(voxelSize=voxel_mm)
    points32 = np.ascontiguousarray(vertices, dtype=np.float32)
    tris32 = np.ascontiguousarray(faces, dtype=np.int32)
    print(
        f"mesh: spot, Loop x{subdivisions}, {len(faces)} faces, {size_mm} mm, voxel {voxel_mm} mm"
    )
    print(f"{'depth_mm':>9} {'robust_s':>9} {'openvdb_s':>10} {'ratio':>7} {'shell_faces':>12}")
    runs = []
    for depth in depths:
        load_before = os.getloadavg()
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            (shell,) = offset_shells(vertices, faces, [depth])
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
        start = time.perf_counter()
        grid = vdb.FloatGrid.createLevelSetFromPolygons(
            points32, triangles=tris32, transform=transform, halfWidth=half_width
        )
        vdb_s = time.perf_counter() - start
        print(
            f"{depth:9.2f} {robust_s:9.2f} {vdb_s:10.2f} {robust_s / vdb_s:7.2f} "
            f"{len(shell.faces):12d}   (vdb active voxels {grid.activeVoxelCount()}) {valid}",
            flush=True,
        )
        runs.append(
            {
                "depth_mm": depth,
                "robust_s": robust_s,
                "openvdb_s": vdb_s,
                "ratio": robust_s / vdb_s,
                "shell_faces": len(shell.faces),
                "openvdb_active_voxels": int(grid.activeVoxelCount()),
                "load_avg_1_5_15_before": list(load_before),
                "load_avg_1_5_15_after": list(os.getloadavg()),
                **valid,
            }
        )
    return {
        "mesh": f"spot, Loop x{subdivisions}",
        "n_faces": len(faces),
        "size_mm": size_mm,
        "voxel_mm": voxel_mm,
        "runs": runs,
    }


def flat() -> dict[str, Any]:
    """Time the robust shells with and without one prism per flat patch."""
    cases = {"colour_target": (ROOT / "data" / "colour_target" / "colour_target.obj", None)}
    airplane = SHARED / "airplane" / "colored_airplane.ply"
    if airplane.is_file():
        cases["airplane_100mm"] = (airplane, 100.0)
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
                load = os.getloadavg()
                start, cpu = time.perf_counter(), time.process_time()
                shells = offset_shells(v, f, [0.5, 0.5])
                row = {
                    "seconds": time.perf_counter() - start,
                    "cpu_seconds": time.process_time() - cpu,
                    "load_avg_1_5_15_before": list(load),
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--part", choices=("quality", "speed", "flat", "both"), default="both")
    parser.add_argument("--meshes", type=str, default="", help="comma list (quality part)")
    parser.add_argument("--size-mm", type=float, default=50.0)
    parser.add_argument("--voxel-mm", type=float, default=0.05)
    parser.add_argument("--depths", type=str, default="0.5,1.0,1.5")
    parser.add_argument("--subdivisions", type=int, default=2, help="Loop subdivisions")
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks" / "results" / "bench_offset.json"
    )
    args = parser.parse_args(argv)
    if not SPOT.is_file():
        print(f"{SPOT} is absent: the benchmark needs ../shared/meshes", file=sys.stderr)
        return 1
    result: dict[str, Any] = json.loads(args.out.read_text()) if args.out.is_file() else {}
    if args.part in ("quality", "both"):
        names = [n for n in args.meshes.split(",") if n] or None
        result.setdefault("quality", {}).update(quality(names))
        result["quality_setup"] = {"thickness_mm": THICKNESS, "n_samples": 20_000}
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    if args.part == "flat":
        result["flat"] = flat()
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    if args.part in ("speed", "both"):
        depths = [float(x) for x in args.depths.split(",")]
        result["speed"] = speed(args.size_mm, args.voxel_mm, depths, args.subdivisions)
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
