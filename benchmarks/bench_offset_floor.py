"""The floor of the union-of-pieces offset: how long manifold3d takes to unite the prisms alone.

Usage: .venv/bin/python benchmarks/bench_offset_floor.py [--depth 0.5] [--cgal-pieces 250]
       [--out benchmarks/results/bench_offset.json]

The robust shells (:mod:`shellvox.offset.robust`) are the part minus the union of one prism per
face, one sector per bending edge and one cap per vertex. This times, in one process on
the issue's 93,696-face spot (Loop x2, 50 mm):

- OpenVDB's ``createLevelSetFromPolygons`` at 0.05 mm with a band reaching `--depth`
  (as ``bench_offset.py --part speed``), before and after the rest;
- the union of the face prisms alone (no sectors, caps, cut or checks), the cheapest
  input any union of per-face pieces has, with :func:`shellvox.offset.union.union_pieces`;
- the exact alternative for resolving an overlapping surface, libigl's CGAL
  ``mesh_boolean`` self-union, against manifold3d on the first `--cgal-pieces` prisms
  along the Morton curve.

Results are merged into --out under ``"floor"``. A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import igl.copyleft.cgal as igl_cgal
import numpy as np
from bench_offset import load_shared
from openvdb_module import load_openvdb

import shellvox.offset.band as band
from shellvox.offset.union import morton_order, union_pieces

ROOT = Path(__file__).resolve().parents[1]
VOXEL_MM = 0.05


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--depth", type=float, default=0.5)
    parser.add_argument("--cgal-pieces", type=int, default=250)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/bench_offset.json")
    args = parser.parse_args(argv)
    mesh = load_shared("spot/spot_triangulated.obj", 50.0, 2)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    groups = band.layer_pieces(band.features(vertices, faces), np.full(len(faces), args.depth))
    prisms = groups[0]
    vdb = load_openvdb()
    transform = vdb.createLinearTransform(voxelSize=VOXEL_MM)
    half_width = float(np.ceil(args.depth / VOXEL_MM) + 2)

    def level_set() -> float:
        start = time.perf_counter()
        vdb.FloatGrid.createLevelSetFromPolygons(
            vertices.astype(np.float32), triangles=faces.astype(np.int32),
            transform=transform, halfWidth=half_width,
        )  # fmt: skip
        return time.perf_counter() - start

    result: dict[str, Any] = {"n_faces": len(faces), "depth_mm": args.depth}
    result["load_avg_before"] = list(os.getloadavg())
    result["openvdb_s"] = [level_set()]
    cpu, start = time.process_time(), time.perf_counter()
    union = union_pieces([prisms])
    result["prisms_union_s"] = time.perf_counter() - start
    result["prisms_union_cpu_s"] = time.process_time() - cpu
    result["prisms"] = len(prisms[0])
    result["prisms_union_triangles"] = union.num_tri()
    result["pieces_all_groups"] = int(sum(len(p) for p, _ in groups))
    result["openvdb_s"].append(level_set())
    result["prisms_union_over_openvdb"] = result["prisms_union_s"] / min(result["openvdb_s"])
    print(json.dumps(result), flush=True)
    points, tris = prisms
    chosen = points[morton_order(points.mean(axis=1))[: args.cgal_pieces]]
    start = time.perf_counter()
    union_pieces([(chosen, tris)])
    manifold_s = time.perf_counter() - start
    n, p = chosen.shape[:2]
    soup = (tris[None] + (np.arange(n) * p)[:, None, None]).reshape(-1, 3)
    start = time.perf_counter()
    igl_cgal.mesh_boolean(
        chosen.reshape(-1, 3), soup, np.zeros((0, 3)), np.zeros((0, 3), np.int64), "union"
    )
    cgal_s = time.perf_counter() - start
    result["cgal_self_union"] = {
        "pieces": n, "manifold3d_s": manifold_s, "libigl_cgal_s": cgal_s,
        "ratio": cgal_s / manifold_s,
    }  # fmt: skip
    result["load_avg_after"] = list(os.getloadavg())
    print(json.dumps(result["cgal_self_union"]), flush=True)
    stored = json.loads(args.out.read_text()) if args.out.exists() else {}
    stored["floor"] = result
    args.out.write_text(json.dumps(stored, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
