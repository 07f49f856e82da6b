"""The shell offsetting methods, one registry: what each is, how it is made, how it is filed.

:data:`METHODS` maps a method's name to a :class:`Method`; :func:`offset_shells` and
:func:`method_shells` dispatch through it, and the command line's choices, the
configuration's check and the documentation read it. The methods:

- ``field`` (the default): each layer's field, the exact distance to the nearest face minus
  that face's cumulative depth (the voxel layers' own rule, :mod:`shellvox.voxel.slab`),
  sampled on a grid and meshed (:mod:`shellvox.offset.field.layer_field`), then simplified
  under an error bound with no crossing (:mod:`shellvox.offset.field.simplify`): closed,
  2-manifold, nested; the files need no cleaning. Its time is estimated from the surface's
  area over the grid step squared (``Method.cost``).
- ``robust`` (a reference): the exact union of per-face convex pieces
  (:mod:`shellvox.offset.reference.robust`): exact creases by construction, minutes on a
  scan; its files are cleaned and jittered (:mod:`shellvox.offset.reference.for_file`).
  It is the oracle the field shells are measured against in tests and benchmarks.
- ``paper`` (a reference): Zhu and Chen's three-plane construction, the seed of the
  per-face offset (:mod:`shellvox.offset.reference.paper`); not guaranteed closed or free of
  crossings on curved or deep input: for comparison, not for printing.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import (
    FloatArray,
    IntArray,
    check_choice,
    check_mesh,
    check_thickness,
)
from shellvox.offset.adjacency import edge_adjacency
from shellvox.offset.field.simplify import DEFAULT_LIMITS, GuardLimits
from shellvox.offset.field.step import (
    BYTES_PER_FIELD_TRIANGLE,
    SECONDS_PER_FIELD_TRIANGLE,
    automatic_step,
    field_triangles,
)
from shellvox.offset.reference.for_file import ShellForFile
from shellvox.offset.shells import Shell

if TYPE_CHECKING:
    from shellvox.offset.field.layer_field import FieldSurfaces

MethodName = Literal["field", "robust", "paper"]


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


#: What a method computes: ``(vertices, faces, depth (K, F) mm, step_mm, limits)``.
Make = Callable[[FloatArray, IntArray, FloatArray, float | None, GuardLimits], MethodShells]


class ShellCost(NamedTuple):
    """What a method's shells are estimated to cost (a build's estimate).

    Attributes
    ----------
    seconds : float
        Time on one core.
    memory_bytes : int
        Working memory at the peak, beyond the model (0: not estimated).
    """

    seconds: float
    memory_bytes: int


#: A method's estimated cost: ``(faces, area mm^2, layers, step_mm or None) -> ShellCost``
#: (``step_mm``: the field's grid step, None for its automatic step).
Cost = Callable[[int, float, int, float | None], ShellCost]


class Method(NamedTuple):
    """One shell offsetting method.

    Attributes
    ----------
    name : str
    summary : str
        One line: what it is and what it costs (the CLI's help, the docs).
    make : callable
        ``(vertices, faces, depth (K, F) mm, step_mm, limits) -> MethodShells``, on
        checked arguments.
    for_file : callable
        ``Shell -> ShellForFile``: the shell made ready for its file.
    reference : bool
        A reference method (exact or historical), not the default's speed.
    closed : bool
        Its shells are closed surfaces (what shell files, layers from shells and FDM
        cores need).
    cost : callable
        Its estimated cost (:data:`Cost`): the field shells' time and memory scale with
        their triangles, the area over the grid step squared
        (:func:`~shellvox.offset.field.step.field_triangles`); the reference methods' time
        with the faces and layers (a rate per face and layer fitted on the benchmarks:
        the performance page), their memory not estimated.
    """

    name: str
    summary: str
    make: Make
    for_file: Callable[[Shell], ShellForFile]
    reference: bool
    closed: bool
    cost: Cost


def _field_cost(n_faces: int, area_mm2: float, layers: int, step_mm: float | None) -> ShellCost:
    if step_mm is None:
        step_mm = automatic_step(area_mm2, layers)
    triangles = field_triangles(area_mm2, layers, step_mm)
    return ShellCost(triangles * SECONDS_PER_FIELD_TRIANGLE, triangles * BYTES_PER_FIELD_TRIANGLE)


def _per_face_layer(seconds: float) -> Cost:
    def cost(n_faces: int, area_mm2: float, layers: int, step_mm: float | None) -> ShellCost:
        return ShellCost(n_faces * layers * seconds, 0)

    return cost


def _shells(meshes: list[tuple[FloatArray, IntArray]], depth: FloatArray) -> list[Shell]:
    return [
        Shell(vertices=mv, faces=mf, layer=k + 1, depth_mm=np.ascontiguousarray(depth[k]))
        for k, (mv, mf) in enumerate(meshes)
    ]


def _field(
    v: FloatArray, f: IntArray, depth: FloatArray, step_mm: float | None, limits: GuardLimits
) -> MethodShells:
    from shellvox.offset.field.layer_field import field_surfaces

    if step_mm is None:
        step_mm = automatic_step(surface_area(v, f), depth.shape[0])
    tick = time.perf_counter()
    field = field_surfaces(v, f, depth, step_mm)
    return field_shells(field, v, f, depth, limits=limits, field_s=time.perf_counter() - tick)


def surface_area(vertices: FloatArray, faces: IntArray) -> float:
    """Return the area of a triangle mesh, mm^2."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return float(0.5 * np.linalg.norm(cross, axis=1).sum())


def field_shells(
    field: FieldSurfaces,
    vertices: FloatArray,
    faces: IntArray,
    depth: FloatArray,
    *,
    limits: GuardLimits = DEFAULT_LIMITS,
    field_s: float = 0.0,
    source: str = "own scan",
) -> MethodShells:
    """Return the ``field`` method's shells from its layers' surfaces, simplified.

    Parameters
    ----------
    field : FieldSurfaces
        The marched layers (:func:`shellvox.offset.field.layer_field.field_surfaces`, or
        a build's :class:`shellvox.offset.field.layer_field.LatticeMesher`).
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        The mesh they offset.
    depth : (K, F) float64, mm
        Cumulative depth of each layer per face.
    limits : GuardLimits, optional
        Bounds of the simplification.
    field_s : float, s
        Seconds the surfaces took (recorded).
    source : str
        Where the nodes' field came from (recorded as ``field_source``).
    """
    from shellvox.offset.field.simplify import simplify_shells
    from shellvox.voxel.geometry._nearest import SurfaceIndex

    tick = time.perf_counter()
    simplified = simplify_shells(
        field.surfaces, SurfaceIndex.build(vertices, faces), depth, limits=limits
    )
    record = {
        "method": "field",
        "step_mm": max(field.grid.voxel_mm),
        "node_step_mm": list(field.grid.voxel_mm),
        "grid_zyx": list(field.grid.shape_zyx),
        "field_source": source,
        "unbalanced_rows": field.n_unbalanced_rows,
        "marched_faces": field.marched_faces,
        "crease_points": field.crease_points,
        "seconds": {"field": field_s, "simplify": time.perf_counter() - tick},
        "simplify": simplified.record,
    }
    return MethodShells(_shells(simplified.meshes, depth), record, simplified.crossing_free)


def _robust(
    v: FloatArray, f: IntArray, depth: FloatArray, step_mm: float | None, limits: GuardLimits
) -> MethodShells:
    from shellvox.offset.reference.robust import robust_offset

    return MethodShells(_shells(robust_offset(v, f, depth), depth), {"method": "robust"})


def _paper(
    v: FloatArray, f: IntArray, depth: FloatArray, step_mm: float | None, limits: GuardLimits
) -> MethodShells:
    from shellvox.offset.reference.paper import paper_offset

    return MethodShells(_shells(paper_offset(v, f, depth), depth), {"method": "paper"})


def _as_made(shell: Shell) -> ShellForFile:
    return ShellForFile(shell, {"cleaning": "none (field shells)"})


def _cleaned(shell: Shell) -> ShellForFile:
    from shellvox.offset.reference.for_file import shell_for_file

    return shell_for_file(shell)


#: Every method by name; the first is the default.
METHODS: dict[str, Method] = {
    "field": Method(
        "field",
        "the layer field meshed and simplified: closed, nested, no crossings, seconds",
        _field,
        _as_made,
        reference=False,
        closed=True,
        cost=_field_cost,
    ),
    "robust": Method(
        "robust",
        "reference: exact Booleans of per-face pieces, exact creases, minutes on a scan",
        _robust,
        _cleaned,
        reference=True,
        closed=True,
        cost=_per_face_layer(1e-2),
    ),
    "paper": Method(
        "paper",
        "reference: Zhu and Chen's three-plane construction, for comparison only",
        _paper,
        _cleaned,
        reference=True,
        closed=False,
        cost=_per_face_layer(2e-5),
    ),
}
DEFAULT_METHOD: MethodName = "field"


def method_shells(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    thickness: npt.ArrayLike,
    *,
    method: MethodName = DEFAULT_METHOD,
    step_mm: float | None = None,
    limits: GuardLimits = DEFAULT_LIMITS,
) -> MethodShells:
    """Offset every face inward by its own cumulative depth; the shells and their record.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
    faces : (F, 3) array_like of int
        Closed, consistently outward-oriented triangles.
    thickness : (K, F) or (K,) array_like of float, mm
        Thickness of each layer per face (``> 0``), outside in; a ``(K,)`` array applies to
        all faces. Layer ``k`` is at cumulative depth ``D_k(f) = sum_{j <= k} t_j(f)``.
    method : {"field", "robust", "paper"}, optional
        A name of :data:`METHODS` (default ``"field"``).
    step_mm : float, mm, optional
        Grid step of ``field`` (> 0); None (default): :func:`automatic_step`.
    limits : GuardLimits, optional
        Bounds of ``field``'s simplification.

    Returns
    -------
    MethodShells

    Raises
    ------
    ValueError
        An unknown method, a bad step, a mesh that is not closed and consistently
        oriented, or a bad thickness.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((4.0, 4.0, 4.0))
    >>> out = method_shells(box.vertices, box.faces, [0.5], step_mm=0.25)
    >>> round(float(out.shells[0].vertices[:, 0].max()), 4), out.record["method"]
    (1.5, 'field')
    """
    chosen = METHODS[check_choice("method", method, METHODS)]
    if step_mm is not None and not (np.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be positive and finite, got {step_mm}")
    v, f = check_mesh(vertices, faces)
    t = check_thickness(thickness, f.shape[0])
    edge_adjacency(f)  # raises ValueError unless closed and consistently oriented
    return chosen.make(v, f, np.cumsum(t, axis=0), step_mm, limits)


def offset_shells(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    thickness: npt.ArrayLike,
    *,
    method: MethodName = DEFAULT_METHOD,
    step_mm: float | None = None,
) -> list[Shell]:
    """Offset every face inward by its own cumulative depth: one closed shell per layer.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
    faces : (F, 3) array_like of int
        Closed, consistently outward-oriented triangles.
    thickness : (K, F) or (K,) array_like of float, mm
        Thickness of each layer per face, outside in; a ``(K,)`` array applies to every
        face. Layer ``k`` lies at the cumulative depth ``D_k(f) = t_1(f) + ... + t_k(f)``.
    method : {"field", "robust", "paper"}
        A method of :data:`shellvox.offset.METHODS` (:mod:`shellvox.offset.methods`).
        ``"field"`` (default): the zero set of each layer's field (the exact distance to
        the nearest face minus that face's depth), meshed and simplified under an error
        bound: closed, 2-manifold, nested, free of crossings; its time is estimated from
        the surface's area over the grid step squared. ``"robust"`` (a reference): exact
        Booleans of per-face pieces, its time with the faces times the layers (slower
        than ``"field"`` on large meshes). ``"paper"`` (a reference): Zhu and Chen's
        construction. Measured times: :doc:`/performance`.
    step_mm : float, mm, optional
        Grid step of ``"field"`` (default: 0.1 mm, coarser on very large surfaces).

    Returns
    -------
    list of Shell
        ``K`` shells, outside in: ``vertices (n, 3) float64 mm``, ``faces (m, 3) int64``,
        ``layer`` (1-based) and ``depth_mm (F,)``.

    Raises
    ------
    ValueError
        A mesh that is not closed and consistently oriented, a bad thickness or method.

    Examples
    --------
    >>> import trimesh
    >>> import shellvox
    >>> box = trimesh.creation.box((10.0, 10.0, 10.0))
    >>> shells = shellvox.offset_shells(box.vertices, box.faces, [0.5, 1.0])
    >>> [round(float(s.vertices[:, 0].max()), 6) for s in shells]
    [4.5, 3.5]
    """
    return method_shells(vertices, faces, thickness, method=method, step_mm=step_mm).shells


def ready_for_file(shell: Shell, method: str) -> ShellForFile:
    """Return a shell ready for its file, as its method wants it.

    The field shells go as they are (their simplification kept them closed, manifold and
    crossing-free, checked); the reference methods' are cleaned and jittered
    (:func:`shellvox.offset.reference.for_file.shell_for_file`).
    """
    return METHODS[check_choice("method", method, METHODS)].for_file(shell)
