"""Independent checks of a shell PLY as other tools read it: trimesh, and MeshLab when present.

Both merge coincident vertices first (trimesh's ``merge_vertices``, MeshLab's
``meshing_remove_duplicate_vertices``), as a slicer does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from meshlab_process import HAVE_PYMESHLAB, meshlab_checks, needs_meshlab

from shellvox.offset.crossing.intersections import count_self_intersections

__all__ = ["HAVE_PYMESHLAB", "header", "meshlab_checks", "needs_meshlab", "trimesh_checks"]


def header(path: Path) -> list[str]:
    """Return the PLY header lines up to ``end_header``."""
    data = Path(path).read_bytes()
    return data[: data.index(b"end_header")].decode("ascii").splitlines()


def _zero_area(vertices: np.ndarray, faces: np.ndarray) -> int:
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return int(np.count_nonzero(np.linalg.norm(cross, axis=1) == 0.0))


def _folded_edges(mesh: trimesh.Trimesh) -> int:
    """Edges whose two faces lie back to back (normals opposite within 1e-6)."""
    normals = np.asarray(mesh.face_normals)
    pairs = np.asarray(mesh.face_adjacency)
    dot = np.einsum("ij,ij->i", normals[pairs[:, 0]], normals[pairs[:, 1]])
    return int(np.count_nonzero(dot < -1.0 + 1e-6))


def trimesh_checks(path: Path) -> dict[str, Any]:
    """Read with trimesh, merge coincident vertices, and measure."""
    mesh = trimesh.load(path, process=False, force="mesh")
    n_vertices = len(mesh.vertices)
    mesh.merge_vertices()
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    return {
        "vertex_dtype": str(np.asarray(trimesh.load(path, process=False).vertices).dtype),
        "merged_vertices": n_vertices - len(v),
        "closed": bool(mesh.is_watertight),
        "oriented": bool(mesh.is_winding_consistent) and float(mesh.volume) > 0,
        "zero_area_faces": _zero_area(v, f),
        "self_intersections": count_self_intersections(v, f),
        "folded_edges": _folded_edges(mesh),
        "n_faces": len(f),
    }
