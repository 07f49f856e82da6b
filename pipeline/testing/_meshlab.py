"""MeshLab (pymeshlab) as an independent reader, always in a process of its own.

pymeshlab crashes the interpreter now and then (segmentation faults after many mesh sets,
PyMeshLab #102). Every call here runs in a fresh spawned process; a process that dies is
retried once in another, and a second death raises :class:`MeshLabCrashedError` naming the
function (a crash that repeats is MeshLab's answer to that input). pymeshlab is imported
in that process only.
"""

from __future__ import annotations

import importlib.util
import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from shellvox.testing._shell_files import count_zero_area_faces

#: Whether pymeshlab can be imported here.
HAVE_PYMESHLAB = importlib.util.find_spec("pymeshlab") is not None

T = TypeVar("T")

#: Seconds one call may take.
TIMEOUT_S = 900.0


class MeshLabCrashedError(AssertionError):
    """MeshLab's process died twice on the same call (a test that meets it fails)."""


def in_own_process(function: Callable[..., T], *args: Any) -> T:
    """Return ``function(*args)`` computed in a new spawned process (one retry if it dies).

    Raises
    ------
    MeshLabCrashedError
        The process died twice.
    ModuleNotFoundError
        pymeshlab is not installed (``pip install 'shellvox[testing]'``).
    """
    if not HAVE_PYMESHLAB:
        raise ModuleNotFoundError(
            "shellvox.testing's MeshLab checks need pymeshlab: pip install 'shellvox[testing]'"
        )
    for _ in range(2):
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(1, mp_context=context) as pool:
            try:
                return pool.submit(function, *args).result(TIMEOUT_S)
            except BrokenProcessPool:
                continue
    raise MeshLabCrashedError(f"MeshLab's process died twice in {function.__name__}{args!r:.200}")


def _file_checks(path: str) -> dict[str, Any]:
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(path)
    ms.meshing_remove_duplicate_vertices()
    topo = ms.get_topological_measures()
    mesh = ms.current_mesh()
    ms.compute_selection_by_self_intersections_per_face()
    return {
        "two_manifold": bool(topo["is_mesh_two_manifold"]),
        "boundary_edges": int(topo["boundary_edges"]),
        "non_manifold_edges": int(topo["non_two_manifold_edges"]),
        "non_manifold_vertices": int(topo["non_two_manifold_vertices"]),
        "zero_area_faces": count_zero_area_faces(mesh.vertex_matrix(), mesh.face_matrix()),
        "self_intersecting_faces": int(ms.current_mesh().selected_face_number()),
        "n_faces": int(mesh.face_number()),
    }


def meshlab_checks(path: str | Path) -> dict[str, Any]:
    """Read a mesh file with MeshLab, remove duplicate vertices, and measure it.

    Returns
    -------
    dict
        ``two_manifold``, ``boundary_edges``, ``non_manifold_edges``,
        ``non_manifold_vertices``, ``zero_area_faces``, ``self_intersecting_faces``,
        ``n_faces``.
    """
    return in_own_process(_file_checks, str(path))


def _crossing_faces(vertices: np.ndarray, faces: np.ndarray, merge: bool) -> int:
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices, face_matrix=faces.astype(np.int32)))
    if merge:
        ms.meshing_remove_duplicate_vertices()
    ms.compute_selection_by_self_intersections_per_face()
    return int(ms.current_mesh().selected_face_number())


def meshlab_crossing_faces(
    vertices: np.ndarray, faces: np.ndarray, *, merge_duplicates: bool = True
) -> int:
    """Return how many faces MeshLab's per-face self-intersection test selects.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int
    merge_duplicates : bool, optional
        Remove duplicate vertices first (as a slicer does).
    """
    return in_own_process(
        _crossing_faces,
        np.asarray(vertices, dtype=np.float64),
        np.asarray(faces),
        merge_duplicates,
    )


def _read(path: str) -> dict[str, np.ndarray]:
    import pymeshlab

    meshes = pymeshlab.MeshSet()
    meshes.load_new_mesh(path)
    mesh = meshes.current_mesh()
    arrays = {"vertices": mesh.vertex_matrix(), "faces": mesh.face_matrix()}
    if mesh.has_face_color():
        arrays["face_colours"] = mesh.face_color_matrix()
    if mesh.has_vertex_color():
        arrays["vertex_colours"] = mesh.vertex_color_matrix()
    if mesh.has_wedge_tex_coord():
        arrays["wedge_uv"] = mesh.wedge_tex_coord_matrix()
    return {name: np.array(values) for name, values in arrays.items()}


def meshlab_read(path: str | Path) -> dict[str, np.ndarray]:
    """Return the arrays MeshLab reads from a mesh file.

    Returns
    -------
    dict
        ``vertices`` (V, 3) and ``faces`` (F, 3); ``face_colours`` (F, 4),
        ``vertex_colours`` (V, 4) (floats 0-1) and ``wedge_uv`` (3 F, 2) when present.
    """
    return in_own_process(_read, str(path))
