"""A shell PLY as trimesh reads it, and the PLY header as text.

trimesh merges coincident vertices first (``merge_vertices``), as a slicer does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def ply_header(path: str | Path) -> list[str]:
    """Return the lines of a PLY file's header, up to ``end_header``."""
    data = Path(path).read_bytes()
    return data[: data.index(b"end_header")].decode("ascii").splitlines()


def count_zero_area_faces(vertices: np.ndarray, faces: np.ndarray) -> int:
    """Return how many faces have an exactly zero cross product of their edges.

    Parameters
    ----------
    vertices : (V, 3) float, mm
    faces : (F, 3) int
    """
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return int(np.count_nonzero(np.linalg.norm(cross, axis=1) == 0.0))


def _folded_edges(normals: np.ndarray, adjacency: np.ndarray) -> int:
    """Edges whose two faces lie back to back (normals opposite within 1e-6)."""
    dot = np.einsum("ij,ij->i", normals[adjacency[:, 0]], normals[adjacency[:, 1]])
    return int(np.count_nonzero(dot < -1.0 + 1e-6))


def trimesh_checks(path: str | Path) -> dict[str, Any]:
    """Read a mesh file with trimesh, merge coincident vertices, and measure it.

    Returns
    -------
    dict
        ``vertex_dtype`` (of the vertices as read), ``merged_vertices`` (how many the merge
        removed), ``closed``, ``oriented`` (consistent winding and a positive volume),
        ``zero_area_faces``, ``self_intersections`` (shellvox's exact crossing test),
        ``folded_edges`` (faces back to back) and ``n_faces``.
    """
    import trimesh

    from shellvox.offset.crossing.intersections import count_self_intersections

    mesh: Any = trimesh.load(path, process=False, force="mesh")  # a Trimesh
    n_vertices = len(mesh.vertices)
    mesh.merge_vertices()
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    as_read: Any = trimesh.load(path, process=False)
    return {
        "vertex_dtype": str(np.asarray(as_read.vertices).dtype),
        "merged_vertices": n_vertices - len(v),
        "closed": bool(mesh.is_watertight),
        "oriented": bool(mesh.is_winding_consistent) and float(mesh.volume) > 0,
        "zero_area_faces": count_zero_area_faces(v, f),
        "self_intersections": count_self_intersections(v, f),
        "folded_edges": _folded_edges(
            np.asarray(mesh.face_normals), np.asarray(mesh.face_adjacency)
        ),
        "n_faces": len(f),
    }
