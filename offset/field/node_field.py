"""The layer field at the grid's nodes, and exactly along its edges.

:class:`NodeField` holds what the scan found at each node of a slab (inside or not, the
nearest face and the squared distance to it) and every level's depth per face;
:func:`node_value` gives a node's value of the layer field ``D_k(f) - d`` from it.

Between two nodes of opposite signs, :func:`edge_crossing` finds where the level's zero set
crosses the edge, from the exact distances to the nodes' nearest faces and their
neighbours (regula falsi), rather than by interpolating the two node values: on a face's
offset plane the crossing is on the plane, so planar parts and the creases between them
(:mod:`shellvox.offset.field.creases`) come out exact. Where the sign changes at a jump of
the depth between two faces (no zero of the field), the crossing keeps the linear share.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.geometry._closest_point import triangle_d2


class NodeField(NamedTuple):
    """The levels' field at a slab of node planes, as :func:`march_slab` reads it.

    Attributes
    ----------
    bits : (P, Y, X) uint8
        Bit ``k`` set where the node is inside level ``k`` (its value ``<= 0``).
    inside : (P, Y, X) bool
        Nodes inside the surface.
    squared : (P, Y, X) float64, mm^2
        Squared distance to the nearest face where ``face >= 0``.
    face : (P, Y, X) int32
        Nearest face, -1 beyond the reach.
    depth : (K, F) float64, mm
        Depth of each level per face: the value of level ``k`` is
        ``depth[k, face] - sqrt(squared)`` inside within reach.
    far : (K,) float64, mm
        Value of level ``k`` inside beyond the reach.
    outside : float, mm
        Value of every level outside.
    origin, step : (3,) float64, mm
        Position ``(x, y, z)`` of node ``(0, 0, 0)`` and the node spacing.
    z_base : int
        Global plane of ``bits[0]``.
    mesh_vertices : (V, 3) float64, mm
    mesh_faces : (F, 3) int64
        The surface whose faces ``face`` names (the crossings are found on it exactly).
    mesh_neighbours : (F, 3) int64
        The faces across each face's edges (-1 where an edge has not exactly two faces).
    mesh_planes : (F, 4) float64
        Every face's unit outward normal ``n`` and level ``n . x`` on its plane (NaN
        without area).
    """

    bits: NDArray[np.uint8]
    inside: NDArray[np.bool_]
    squared: NDArray[np.float64]
    face: NDArray[np.int32]
    depth: NDArray[np.float64]
    far: NDArray[np.float64]
    outside: float
    origin: NDArray[np.float64]
    step: NDArray[np.float64]
    z_base: int
    mesh_vertices: NDArray[np.float64]
    mesh_faces: NDArray[np.int64]
    mesh_neighbours: NDArray[np.int64]
    mesh_planes: NDArray[np.float64]


@kernel(inline="always")
def node_value(field: NodeField, k: int, z: int, y: int, x: int) -> float:
    """Layer field ``D_k(f) - d`` of one node (see :class:`NodeField`)."""
    if not field.inside[z, y, x]:
        return field.outside
    f = field.face[z, y, x]
    if f < 0:
        return float(field.far[k])
    return float(field.depth[k, f] - np.sqrt(field.squared[z, y, x]))


@kernel(inline="always")
def near_face(field: NodeField, z: int, y: int, x: int) -> int:
    """Nearest face of a node inside within reach, else -1."""
    if not field.inside[z, y, x]:
        return -1
    return int(field.face[z, y, x])


#: Largest |field| (mm) at a crossing found on an edge; a sign change with more is a
#: jump of the depth between two faces, and the edge keeps its linear share.
ROOT_TOLERANCE_MM = 1e-9

#: Largest excess (mm) of a point's distance to a face over its distance to the face's
#: plane for the point to count as on the face's offset plane.
ON_PLANE_MM = 1e-10

#: Faces an edge's crossing is found with at most (the nodes' and their neighbours').
MAX_FACES = 6

#: Steps of the root search along an edge.
ROOT_STEPS = 60


@kernel(inline="always")
def foot_inside(
    field: NodeField, f: int, z: int, y: int, x: int, p: tuple[float, float, float]
) -> bool:
    """Whether node ``p``'s nearest point on face ``f`` is its foot on the face's plane.

    Its distance (the scan's) equals its distance to the plane within ``ON_PLANE_MM``.
    """
    planes = field.mesh_planes
    behind = planes[f, 3] - (planes[f, 0] * p[0] + planes[f, 1] * p[1] + planes[f, 2] * p[2])
    return bool(np.sqrt(field.squared[z, y, x]) - abs(behind) <= ON_PLANE_MM)


@kernel(inline="always")
def _face_field(
    field: NodeField, k: int, f: int, p0: float, p1: float, p2: float
) -> tuple[float, float, bool]:
    """Return the squared distance from ``p`` to face ``f``, its depth, and whether on plane.

    On plane: the distance is the one to the face's plane within ``ON_PLANE_MM`` (the
    nearest point is the point's foot on the plane).
    """
    # scalars, not row views (a view per corner costs more than the arithmetic)
    i0, i1, i2 = field.mesh_faces[f, 0], field.mesh_faces[f, 1], field.mesh_faces[f, 2]
    a0, a1, a2 = field.mesh_vertices[i0, 0], field.mesh_vertices[i0, 1], field.mesh_vertices[i0, 2]
    b0, b1, b2 = field.mesh_vertices[i1, 0], field.mesh_vertices[i1, 1], field.mesh_vertices[i1, 2]
    c0, c1, c2 = field.mesh_vertices[i2, 0], field.mesh_vertices[i2, 1], field.mesh_vertices[i2, 2]
    u0, u1, u2 = b0 - a0, b1 - a1, b2 - a2
    w0, w1, w2 = c0 - a0, c1 - a1, c2 - a2
    n0, n1, n2 = u1 * w2 - u2 * w1, u2 * w0 - u0 * w2, u0 * w1 - u1 * w0
    norm2 = n0 * n0 + n1 * n1 + n2 * n2
    depth = float(field.depth[k, f])
    if norm2 > 0.0:
        r0, r1, r2 = p0 - a0, p1 - a1, p2 - a2
        # the foot's barycentric weights of b and c (signed areas over the whole)
        v = ((r1 * w2 - r2 * w1) * n0 + (r2 * w0 - r0 * w2) * n1 + (r0 * w1 - r1 * w0) * n2) / norm2
        w = ((u1 * r2 - u2 * r1) * n0 + (u2 * r0 - u0 * r2) * n1 + (u0 * r1 - u1 * r0) * n2) / norm2
        if v >= 0.0 and w >= 0.0 and v + w <= 1.0:
            along = n0 * r0 + n1 * r1 + n2 * r2
            return along * along / norm2, depth, True
    d2 = triangle_d2(p0, p1, p2, a0, a1, a2, b0, b1, b2, c0, c1, c2)
    on_plane = False
    if norm2 > 0.0:
        plane = abs(n0 * (p0 - a0) + n1 * (p1 - a1) + n2 * (p2 - a2)) / np.sqrt(norm2)
        on_plane = np.sqrt(d2) - plane <= ON_PLANE_MM
    return d2, depth, on_plane


@kernel(inline="always")
def _near_field(
    field: NodeField, k: int, faces: NDArray[np.int64], n: int, p0: float, p1: float, p2: float
) -> tuple[float, int, bool, float]:
    """Return layer ``k``'s field at ``p`` from the nearest of ``faces[:n]``.

    Ties go to the lower index. Also returns that face, whether its nearest point is the
    foot on its plane, and the squared distance.
    """
    best_d2, best_f, best_on, best_depth = np.inf, -1, False, 0.0
    for i in range(n):
        f = faces[i]
        d2, depth, on_plane = _face_field(field, k, f, p0, p1, p2)
        if d2 < best_d2 or (d2 == best_d2 and f < best_f):
            best_d2, best_f, best_on, best_depth = d2, f, on_plane, depth
    return best_depth - np.sqrt(best_d2), best_f, best_on, best_d2


@kernel
def edge_crossing(
    field: NodeField,
    k: int,
    a: tuple[float, float, float],
    b: tuple[float, float, float],
    fa: int,
    fb: int,
    va: float,
    vb: float,
    faces: NDArray[np.int64],
) -> tuple[float, int]:
    """Where layer ``k``'s zero set crosses the grid edge from node ``a`` to node ``b``.

    The field along the edge is computed exactly from the nodes' nearest faces ``fa`` and
    ``fb`` (the nearer of the two at every point), and its zero found by regula falsi
    (Illinois) between the node values ``va`` and ``vb`` (opposite signs). A face's field
    is linear where its nearest point lies inside the face, so on a planar part the first
    step is exact. Where a face next to one of those is nearer at the zero found, it joins
    them and the zero is found again (up to ``MAX_FACES`` faces), listed in ``faces``
    ((MAX_FACES,) int64, scratch).

    Returns
    -------
    share : float
        Place of the crossing from ``a`` (0) to ``b`` (1); the linear share
        ``va / (va - vb)`` where the sign changes at a jump of the depth between two
        faces (not a zero of the field).
    face : int
        The face whose offset plane the crossing lies on (its nearest point inside the
        face), -1 if none.
    """
    linear = va / (va - vb)
    faces[0] = fa
    n = 1
    if fb != fa:
        faces[1] = fb
        n = 2
    t, value, face, on_plane = linear, 0.0, -1, False
    for _ in range(MAX_FACES):
        t, value, face, on_plane, d2 = _root(field, k, a, b, faces, n, va, vb, linear)
        if fa == fb and on_plane and abs(value) <= ROOT_TOLERANCE_MM:
            break  # one face, its plane: the linear field of both nodes
        # a neighbour of the faces so far nearer at the zero joins them
        nearer, nearer_d2 = -1, d2
        p0 = a[0] + t * (b[0] - a[0])
        p1 = a[1] + t * (b[1] - a[1])
        p2 = a[2] + t * (b[2] - a[2])
        for i in range(n):
            for m in range(3):
                g = field.mesh_neighbours[faces[i], m]
                if g < 0:
                    continue
                known = False
                for q in range(n):
                    known = known or faces[q] == g
                if known:
                    continue
                # no nearer than its plane: skipped where the plane is not nearer
                planes = field.mesh_planes
                behind = planes[g, 3] - (planes[g, 0] * p0 + planes[g, 1] * p1 + planes[g, 2] * p2)
                if behind * behind >= nearer_d2 * (1.0 - 1e-12):
                    continue
                g_d2, _, _ = _face_field(field, k, g, p0, p1, p2)
                if g_d2 < nearer_d2 * (1.0 - 1e-12):
                    nearer, nearer_d2 = g, g_d2
        if nearer < 0 or n == MAX_FACES:
            break
        faces[n] = nearer
        n += 1
    if abs(value) > ROOT_TOLERANCE_MM:
        return linear, -1
    return t, face if on_plane else -1


@kernel(inline="always")
def _root(
    field: NodeField,
    k: int,
    a: tuple[float, float, float],
    b: tuple[float, float, float],
    faces: NDArray[np.int64],
    n: int,
    va: float,
    vb: float,
    first: float,
) -> tuple[float, float, int, bool, float]:
    """Find the zero of the field of ``faces[:n]`` along the edge by regula falsi.

    The Illinois variant, from ``first``; returns the place, the field there, its face,
    whether on its plane, and the squared distance.
    """
    lo, f_lo, hi, f_hi = 0.0, va, 1.0, vb
    t, side = first, 0
    value, face, on_plane, d2 = 0.0, -1, False, 0.0
    for _ in range(ROOT_STEPS):
        value, face, on_plane, d2 = _near_field(
            field,
            k,
            faces,
            n,
            a[0] + t * (b[0] - a[0]),
            a[1] + t * (b[1] - a[1]),
            a[2] + t * (b[2] - a[2]),
        )
        if abs(value) <= ROOT_TOLERANCE_MM * 1e-3 or hi - lo <= 1e-15:
            break
        if (value <= 0.0) == (f_lo <= 0.0):
            lo, f_lo = t, value
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = t, value
            if side == 1:
                f_lo *= 0.5
            side = 1
        t = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        if not lo < t < hi:
            t = 0.5 * (lo + hi)
    return t, value, face, on_plane, d2
