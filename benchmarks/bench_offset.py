"""Time the robust offset on a ~100k-face mesh against OpenVDB's mesh-to-level-set.

Usage: .venv/bin/python benchmarks/bench_offset.py [--size-mm 50] [--voxel-mm 0.05]

The mesh is ../shared/meshes/spot (5856 faces) with two Loop subdivisions (93,696 faces),
scaled so its largest extent is --size-mm. For each depth the robust offset is timed
(one layer), and OpenVDB's createLevelSetFromPolygons at --voxel-mm with a narrow band
just wide enough to hold that depth. A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from offset import offset_shells
from voxel.openvdb_module import load_openvdb

SPOT = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "spot" / "spot_triangulated.obj"


def load_mesh(size_mm: float, subdivisions: int) -> trimesh.Trimesh:
    raw = trimesh.load(SPOT, force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    if subdivisions > 0:
        mesh = mesh.subdivide_loop(iterations=subdivisions)
    mesh.apply_scale(size_mm / mesh.extents.max())
    assert mesh.is_watertight and mesh.is_winding_consistent
    return mesh


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size-mm", type=float, default=50.0)
    parser.add_argument("--voxel-mm", type=float, default=0.05)
    parser.add_argument("--depths", type=str, default="0.5,1.0,1.5")
    parser.add_argument("--subdivisions", type=int, default=2, help="Loop subdivisions")
    args = parser.parse_args(argv)
    if not SPOT.is_file():
        print(f"{SPOT} is absent: the benchmark needs ../shared/meshes", file=sys.stderr)
        return 1
    mesh = load_mesh(args.size_mm, args.subdivisions)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    vdb = load_openvdb()
    transform = vdb.createLinearTransform(voxelSize=args.voxel_mm)
    points32 = np.ascontiguousarray(vertices, dtype=np.float32)
    tris32 = np.ascontiguousarray(faces, dtype=np.int32)
    print(
        f"mesh: spot, Loop x{args.subdivisions}, {len(faces)} faces, {args.size_mm} mm, "
        f"voxel {args.voxel_mm} mm"
    )
    print(f"{'depth_mm':>9} {'robust_s':>9} {'openvdb_s':>10} {'ratio':>7} {'shell_faces':>12}")
    for depth in (float(x) for x in args.depths.split(",")):
        start = time.perf_counter()
        (shell,) = offset_shells(vertices, faces, [depth])
        robust_s = time.perf_counter() - start
        half_width = float(np.ceil(depth / args.voxel_mm) + 2)
        start = time.perf_counter()
        grid = vdb.FloatGrid.createLevelSetFromPolygons(
            points32, triangles=tris32, transform=transform, halfWidth=half_width
        )
        vdb_s = time.perf_counter() - start
        print(
            f"{depth:9.2f} {robust_s:9.2f} {vdb_s:10.2f} {robust_s / vdb_s:7.2f} "
            f"{len(shell.faces):12d}   (vdb active voxels {grid.activeVoxelCount()})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
