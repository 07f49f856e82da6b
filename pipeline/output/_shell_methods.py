"""The offset shells by method: ``field`` (the default), ``robust`` or ``paper``.

``field`` meshes the zero set of each layer's field, the exact distance to the nearest face
minus that face's cumulative depth (the rule of the voxel layers, :mod:`shellvox.voxel.slab`),
sampled on a grid of step ``step_mm`` (:mod:`shellvox.offset.field.layer_field`: marching
tetrahedra, closed, 2-manifold, free of self-intersections and nested by construction), then
simplifies the shells under an error bound and a no-crossing check
(:mod:`shellvox.offset.field.simplify`). ``robust`` and ``paper`` are
:func:`shellvox.offset.offset_shells`' exact Booleans and the paper's reference construction. The
``field`` shells need no cleaning for their files.
"""

from __future__ import annotations

import math
import time
from typing import Any, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from shellvox.model import face_areas
from shellvox.offset import offset_shells
from shellvox.offset._validate import check_choice, check_mesh, check_thickness
from shellvox.offset.adjacency import edge_adjacency
from shellvox.offset.field.layer_field import field_surfaces
from shellvox.offset.field.simplify import DEFAULT_LIMITS, GuardLimits, simplify_shells
from shellvox.offset.reference.for_file import ShellForFile, shell_for_file
from shellvox.offset.shells import Shell
from shellvox.voxel.geometry._nearest import SurfaceIndex

ShellMethod = Literal["field", "robust", "paper"]
SHELL_METHODS: tuple[str, ...] = ("field", "robust", "paper")

#: Default grid step of the ``field`` shells (``--shell-step``), mm. On spot at 100 mm
#: (93,696 faces, depths 0.5 and 1.5 mm) 0.1 mm gave |d - D| p99 1.3 um and max 25 um before
#: simplification; 0.05 mm halves the error at four times the triangles and eight times the
#: nodes (benchmarks/bench_field_shells.py).
SHELL_STEP_MM = 0.1

#: Marching-tetrahedra triangles of one layer per mm^2 of surface times the step squared
#: (spot at 100 mm: 16.5 M triangles of 19,127 mm^2 at 0.1 mm, 8.6).
TRIANGLES_PER_AREA = 8.7

#: Triangles all layers may have before simplification at the automatic step (about 320
#: bytes each at the peak: 11.5 GB; spot at 100 mm, two layers, 31.6 M, keeps 0.1 mm).
MAX_FIELD_TRIANGLES = 36_000_000


def automatic_step(area_mm2: float, layers: int) -> float:
    """Return the grid step of the ``field`` shells for a surface (mm).

    ``SHELL_STEP_MM``, raised (to whole hundredths of a mm) where the layers' triangles
    before simplification would pass ``MAX_FIELD_TRIANGLES``; a 120 mm polyhedron of
    53,660 mm^2 with two layers gets 0.17 mm.

    >>> automatic_step(19127.0, 2), automatic_step(53660.0, 2)
    (0.1, 0.17)
    """
    needed = math.sqrt(TRIANGLES_PER_AREA * area_mm2 * layers / MAX_FIELD_TRIANGLES)
    return max(SHELL_STEP_MM, math.ceil(round(needed * 100.0, 6)) / 100.0)


class MethodShells(NamedTuple):
    """Shells of one method and its record.

    Attributes
    ----------
    shells : list of Shell
        Outside in.
    record : dict
        ``method``; for ``field``: ``step_mm``, ``grid_zyx``, ``seconds`` (``field``,
        ``simplify``) and the simplification's record.
    crossing_free : bool
        The shells, all together, were tested and no two of their triangles cross
        (``field``, when simplified:
        :attr:`shellvox.offset.field.simplify.Simplified.crossing_free`).
    """

    shells: list[Shell]
    record: dict[str, Any]
    crossing_free: bool = False


def method_shells(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    thickness: npt.ArrayLike,
    *,
    method: ShellMethod = "field",
    step_mm: float | None = None,
    limits: GuardLimits = DEFAULT_LIMITS,
) -> MethodShells:
    """Offset every face inward by its own cumulative depth with the chosen method.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
    faces : (F, 3) array_like of int
        Closed, consistently outward-oriented triangles.
    thickness : (K, F) or (K,) array_like of float, mm
        Thickness of each layer per face (``> 0``), outside in.
    method : {"field", "robust", "paper"}, optional
    step_mm : float, mm, optional
        Grid step of ``field`` (> 0); None (default): :func:`automatic_step`.
    limits : GuardLimits, optional
        Bounds of ``field``'s simplification.

    Returns
    -------
    MethodShells

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((4.0, 4.0, 4.0))
    >>> out = method_shells(box.vertices, box.faces, [0.5], step_mm=0.25)
    >>> round(float(out.shells[0].vertices[:, 0].max()), 4)
    1.5
    """
    chosen = check_choice("method", method, SHELL_METHODS)
    if chosen != "field":
        shells = offset_shells(vertices, faces, thickness, method=chosen)  # type: ignore[arg-type]
        return MethodShells(shells, {"method": chosen})
    if step_mm is not None and not (np.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be positive and finite, got {step_mm}")
    v, f = check_mesh(vertices, faces)
    t = check_thickness(thickness, f.shape[0])
    if step_mm is None:
        step_mm = automatic_step(float(face_areas(v, f).sum()), t.shape[0])
    edge_adjacency(f)  # raises ValueError unless closed and consistently oriented
    depth = np.cumsum(t, axis=0)
    tick = time.perf_counter()
    field = field_surfaces(v, f, depth, step_mm)
    field_s = time.perf_counter() - tick
    simplified = simplify_shells(field.surfaces, SurfaceIndex.build(v, f), depth, limits=limits)
    shells = [
        Shell(vertices=sv, faces=sf, layer=k + 1, depth_mm=np.ascontiguousarray(depth[k]))
        for k, (sv, sf) in enumerate(simplified.meshes)
    ]
    record = {
        "method": "field",
        "step_mm": step_mm,
        "grid_zyx": list(field.grid.shape_zyx),
        "unbalanced_rows": field.n_unbalanced_rows,
        "marched_faces": field.marched_faces,
        "seconds": {"field": field_s, "simplify": time.perf_counter() - tick - field_s},
        "simplify": simplified.record,
    }
    return MethodShells(shells, record, crossing_free=simplified.crossing_free)


def ready_for_file(shell: Shell, method: str) -> ShellForFile:
    """Return a shell ready for its file: as it is for ``field``, else cleaned and jittered.

    The field shells have no vertex clusters or slivers to clean (their simplification kept
    them closed, manifold and crossing-free, checked); the exact ones go through
    :func:`shellvox.offset.reference.for_file.shell_for_file`.
    """
    if method == "field":
        return ShellForFile(shell, {"cleaning": "none (field shells)"})
    return shell_for_file(shell)
