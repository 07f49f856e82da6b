"""Independent checks of a shell PLY as other tools read it: trimesh, and MeshLab when present.

Both merge coincident vertices first (trimesh's ``merge_vertices``, MeshLab's
``meshing_remove_duplicate_vertices``), as a slicer does.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from offset.intersections import count_self_intersections

HAVE_PYMESHLAB = importlib.util.find_spec("pymeshlab") is not None


def header(path: Path) -> list[str]:
    """Return the PLY header lines up to ``end_header``."""
    data = Path(path).read_bytes()
    return data[: data.index(b"end_header")].decode("ascii").splitlines()


def _zero_area(vertices: np.ndarray, faces: np.ndarray) -> int:
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return int(np.count_nonzero(np.linalg.norm(cross, axis=1) == 0.0))


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
        "n_faces": len(f),
    }


def meshlab_checks(path: Path) -> dict[str, Any]:
    """Read with pymeshlab, remove duplicate vertices, and measure."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.meshing_remove_duplicate_vertices()
    topo = ms.get_topological_measures()
    mesh = ms.current_mesh()
    ms.compute_selection_by_self_intersections_per_face()
    return {
        "two_manifold": bool(topo["is_mesh_two_manifold"]),
        "boundary_edges": int(topo["boundary_edges"]),
        "non_manifold_edges": int(topo["non_two_manifold_edges"]),
        "non_manifold_vertices": int(topo["non_two_manifold_vertices"]),
        "zero_area_faces": _zero_area(mesh.vertex_matrix(), mesh.face_matrix()),
        "self_intersecting_faces": int(ms.current_mesh().selected_face_number()),
        "n_faces": int(mesh.face_number()),
    }


def meshlab_flags_are_coplanar_pairs(path: Path) -> bool:
    """Return whether every face MeshLab flags as self-intersecting has a coplanar neighbour.

    MeshLab's triangle-triangle test (vcg's ``NoDivTriTriIsect``) has no tolerance for
    coplanar triangles: two triangles of one plane whose boxes overlap are reported when
    the round-off signs of their plane distances differ. A flagged face is explained when
    another face sharing at most one vertex lies in its plane (normals within 1e-9 and
    corners within 1e-9 mm) with an overlapping box.
    """
    import pymeshlab

    from offset.intersections import _candidate_pairs

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.compute_selection_by_self_intersections_per_face()
    flagged = ms.current_mesh().face_selection_array()
    mesh = trimesh.load(path, process=False, force="mesh")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    tri = v[f]
    a, b = _candidate_pairs(tri.min(axis=1), tri.max(axis=1))
    keep = (f[a][:, :, None] == f[b][:, None, :]).any(axis=2).sum(axis=1) < 2
    a, b = a[keep], b[keep]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    dist = np.abs(np.einsum("pij,pj->pi", tri[b] - tri[a][:, :1], n[a])).max(axis=1)
    coplanar = (np.abs(np.einsum("ij,ij->i", n[a], n[b])) > 1 - 1e-9) & (dist < 1e-9)
    partner = np.zeros(len(f), dtype=bool)
    partner[a[coplanar]] = True
    partner[b[coplanar]] = True
    return bool(np.all(partner[flagged]))
