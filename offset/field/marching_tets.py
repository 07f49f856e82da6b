r"""Marching tetrahedra on the Freudenthal (Kuhn) split of a grid, slab by slab, several levels.

Every cube of the node grid is split into the six tetrahedra along its main diagonal
``(0, 0, 0) - (1, 1, 1)``: for each order ``(a, b, c)`` of the axes, the tetrahedron
``0, e_a, e_a + e_b, e_a + e_b + e_c``. Every cube is split the same way, so the split of a
shared face (its diagonal runs from its lowest to its highest corner) agrees between the two
cubes: together the tetrahedra are a triangulation of the grid (Freudenthal [1]_), whose
edges from a node go along the seven directions ``(dx, dy, dz)`` in ``{0, 1}^3 \ {0}``.

On that triangulation the field, linear inside each tetrahedron, is piecewise linear and
its zero set is a polygon (triangle or planar quad) in each tetrahedron crossed by it.
Each crossed grid edge gets one vertex, shared by all the tetrahedra around the edge, so
the surface is closed and 2-manifold; each piece lies inside its own tetrahedron, so the
surface does not cross itself. Ties are broken symbolically: a node where the field is
exactly zero counts as inside (negative), as if the level were raised by an infinitesimal,
so no vertex falls on a node and no polygon degenerates (the vertex's place along its edge
is kept at least ``EDGE_MARGIN`` of the edge from either node). Two levels whose node values
are ordered (a deeper layer lower at every node) give zero sets nested by construction.
The float64 vertices keep that: on the 93,696-face spot at 100 mm, step 0.1 mm (31.6
million triangles in two layers), no pair crosses in exact arithmetic; a float test with a
tolerance reports pairs among the vertices clustered within a micrometre of a node where
the field is nearly zero (see :mod:`shellvox.offset.crossing.exact_crossing`).

A node's sign bits come in (one bit per level, set when inside); the field value is only
computed on crossed edges, by a caller-supplied rule (:mod:`shellvox.offset.field.layer_field`:
the distance to the nearest face minus that face's depth). Triangles are oriented with
their normal towards the positive side (outward for a signed distance negative inside).

References
----------
.. [1] H. Freudenthal, "Simplizialzerlegungen von beschraenkter Flachheit", Annals of
   Mathematics 43(3), 1942; A. Doi, A. Koide, "An efficient method of triangulating
   equi-valued surfaces by using tetrahedral cells", IEICE Trans. E74(1), 1991.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.geometry._closest_point import triangle_d2

#: Smallest place of a vertex along its edge, as a share of the edge from either node.
EDGE_MARGIN = 1e-6

#: The seven edge directions ``(dx, dy, dz)`` from a node; the first three stay in the plane.
DIRECTIONS = np.array(
    [[1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]], dtype=np.int64
)


def _tables() -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Return the edge list of a cube and the triangle table of its six tetrahedra.

    Returns ``edges (19, 4)`` (start corner ``cx, cy, cz`` and direction index),
    ``tets (6, 4)`` (corner codes ``cx + 2 cy + 4 cz``) and ``table (6, 16, 2, 3)`` (local
    edge ids of up to two triangles per tetrahedron and inside-pattern, -1 unused).
    """
    corners = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])
    edges = []
    for corner in range(8):
        for direction in range(7):
            end = corners[corner] + DIRECTIONS[direction]
            if end.max() <= 1:
                edges.append([*corners[corner], direction])
    edge_array = np.array(edges, dtype=np.int64)
    edge_of = {(int(e[0] + 2 * e[1] + 4 * e[2]), int(e[3])): i for i, e in enumerate(edge_array)}
    tets = []
    for order in itertools.permutations(range(3)):
        path = [0]
        for axis in order:
            path.append(path[-1] | (1 << axis))
        tets.append(path)
    tet_array = np.array(tets, dtype=np.int64)
    table = np.full((6, 16, 2, 3), -1, dtype=np.int64)
    for t, tet in enumerate(tets):
        points = corners[tet].astype(np.float64)
        for case in range(1, 15):
            inside = [(case >> i) & 1 for i in range(4)]
            value = np.array([-1.0 if s else 1.0 for s in inside])
            # Gradient of the linear interpolant of `value` over the tetrahedron.
            gradient = np.linalg.solve(points[1:] - points[0], value[1:] - value[0])

            def edge(i: int, j: int, tet: list[int] = tet) -> int:
                a, b = sorted((tet[i], tet[j]))  # a path's corners grow bitwise: b = a | d
                direction = int(np.flatnonzero((corners[b] - corners[a] == DIRECTIONS).all(1))[0])
                return edge_of[(a, direction)]

            minus = [i for i in range(4) if inside[i]]
            plus = [i for i in range(4) if not inside[i]]
            lone, rest = (minus, plus) if len(minus) == 1 else (plus, minus)
            if len(lone) == 1:
                polygon = [(lone[0], r) for r in rest]
            else:
                (i, j), (k, m) = minus, plus
                polygon = [(i, k), (i, m), (j, m), (j, k)]
            middle = [(points[a] + points[b]) / 2 for a, b in polygon]
            triangles = [[0, 1, 2]] if len(polygon) == 3 else [[0, 1, 2], [0, 2, 3]]
            for n, tri in enumerate(triangles):
                normal = np.cross(middle[tri[1]] - middle[tri[0]], middle[tri[2]] - middle[tri[0]])
                if normal @ gradient < 0:
                    tri = [tri[0], tri[2], tri[1]]
                table[t, case, n] = [edge(*polygon[v]) for v in tri]
    return edge_array, tet_array, table


EDGES, TETS, TABLE = _tables()
TRIANGLES_PER_CASE = (TABLE[:, :, :, 0] >= 0).sum(axis=2).astype(np.int64)
DIRECTIONS_NB = DIRECTIONS.copy()  # a global array numba freezes at compile time


@kernel
def count_triangles(
    bits: NDArray[np.uint8], n_levels: int, tets: NDArray[np.int64], per_case: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Return the triangles each level makes in the cubes of a slab of nodes.

    Parameters
    ----------
    bits : (P, Y, X) uint8
        Bit ``k`` of a node is set when the node is inside level ``k``.
    n_levels : int
        Levels ``K <= 8``.
    tets, per_case : the module's ``TETS`` and ``TRIANGLES_PER_CASE``.

    Returns
    -------
    (K,) int64
    """
    n_p, n_y, n_x = bits.shape
    counts = np.zeros(n_levels, dtype=np.int64)
    corner = np.zeros(8, dtype=np.uint8)
    for z in range(n_p - 1):
        for y in range(n_y - 1):
            r00, r01 = bits[z, y], bits[z, y + 1]
            r10, r11 = bits[z + 1, y], bits[z + 1, y + 1]
            for x in range(n_x - 1):
                low = r00[x] & r00[x + 1] & r01[x] & r01[x + 1]
                low &= r10[x] & r10[x + 1] & r11[x] & r11[x + 1]
                high = r00[x] | r00[x + 1] | r01[x] | r01[x + 1]
                high |= r10[x] | r10[x + 1] | r11[x] | r11[x + 1]
                if low == high:
                    continue
                corner[0], corner[1], corner[2], corner[3] = r00[x], r00[x + 1], r01[x], r01[x + 1]
                corner[4], corner[5], corner[6], corner[7] = r10[x], r10[x + 1], r11[x], r11[x + 1]
                for k in range(n_levels):
                    if ((low >> k) & 1) == ((high >> k) & 1):
                        continue
                    for t in range(6):
                        case = 0
                        for i in range(4):
                            case |= ((corner[tets[t, i]] >> k) & 1) << i
                        counts[k] += per_case[t, case]
    return counts


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


class VertexIds(NamedTuple):
    """Vertex ids of the crossed edges, kept from slab to slab (updated in place).

    Attributes
    ----------
    plane_ids : (2, K, Y, X, 3) int64
        Vertex ids of the in-plane edges of the planes of parity 0 and 1 (-1 at first).
    between_ids : (K, Y, X, 4) int64
        Vertex ids of the edges leaving a plane upwards (scratch, -1 at first).
    state : (2, K) int64
        Row 0: the next vertex id of each level; row 1: the first id made in the last cube
        layer.
    """

    plane_ids: NDArray[np.int64]
    between_ids: NDArray[np.int64]
    state: NDArray[np.int64]


class MarchOutputs(NamedTuple):
    """Where :func:`march_slab` writes a slab's new vertices and triangles.

    Attributes
    ----------
    vertices : (sum V_k, 3) float64, mm
        Output: the new vertices of level ``k`` from row ``v_start[k]`` on.
    v_start : (K,) int64
        First row of each level in ``vertices``.
    faces : (sum T_k, 3) int64
        Output: level ``k``'s triangles from row ``f_start[k]`` on (ids per level).
    f_start : (K,) int64
        First row of each level in ``faces``.
    vertex_face : (sum V_k,) int32
        Output: the face whose offset plane a vertex lies on (its nearest face, the nearest
        point inside it), -1 elsewhere (see :func:`edge_crossing`).
    """

    vertices: NDArray[np.float64]
    v_start: NDArray[np.int64]
    faces: NDArray[np.int64]
    f_start: NDArray[np.int64]
    vertex_face: NDArray[np.int32]


@kernel(inline="always")
def _node_value(field: NodeField, k: int, z: int, y: int, x: int) -> float:
    """Layer field ``D_k(f) - d`` of one node (see :class:`NodeField`)."""
    if not field.inside[z, y, x]:
        return field.outside
    f = field.face[z, y, x]
    if f < 0:
        return float(field.far[k])
    return float(field.depth[k, f] - np.sqrt(field.squared[z, y, x]))


@kernel(inline="always")
def _near_face(field: NodeField, z: int, y: int, x: int) -> int:
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
def _foot_inside(
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


@kernel
def march_slab(
    field: NodeField,
    ids: VertexIds,
    tables: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]],
    out: MarchOutputs,
) -> NDArray[np.int64]:
    """Mesh the zero sets of ``K`` levels in the cubes of a slab of node planes.

    Parameters
    ----------
    field : NodeField
        The nodes' sign bits and what their values are computed from.
    ids : VertexIds
        The vertex ids of crossed edges (updated).
    tables : the module's ``(EDGES, TETS, TABLE)``.
    out : MarchOutputs
        The slab's new vertices and triangles, filled in place.

    Returns
    -------
    (K,) int64
        New vertices of each level.
    """
    bits, depth, origin, step = field.bits, field.depth, field.origin, field.step
    plane_ids, between_ids, state = ids
    vertices, v_start, faces, f_start, vertex_face = out
    edges, tets, table = tables
    n_p, n_y, n_x = bits.shape
    n_levels = depth.shape[0]
    made = np.zeros(n_levels, dtype=np.int64)
    n_faces = np.zeros(n_levels, dtype=np.int64)
    corner = np.zeros(8, dtype=np.uint8)
    scratch = np.empty(MAX_FACES, dtype=np.int64)
    for z in range(n_p - 1):
        g = field.z_base + z
        previous = state[1].copy()
        current = state[0].copy()
        for y in range(n_y - 1):
            r00, r01 = bits[z, y], bits[z, y + 1]
            r10, r11 = bits[z + 1, y], bits[z + 1, y + 1]
            for x in range(n_x - 1):
                low = r00[x] & r00[x + 1] & r01[x] & r01[x + 1]
                low &= r10[x] & r10[x + 1] & r11[x] & r11[x + 1]
                high = r00[x] | r00[x + 1] | r01[x] | r01[x + 1]
                high |= r10[x] | r10[x + 1] | r11[x] | r11[x + 1]
                if low == high:
                    continue
                corner[0], corner[1], corner[2], corner[3] = r00[x], r00[x + 1], r01[x], r01[x + 1]
                corner[4], corner[5], corner[6], corner[7] = r10[x], r10[x + 1], r11[x], r11[x + 1]
                for k in range(n_levels):
                    if ((low >> k) & 1) == ((high >> k) & 1):
                        continue
                    for t in range(6):
                        case = 0
                        for i in range(4):
                            case |= ((corner[tets[t, i]] >> k) & 1) << i
                        for n in range(2):
                            if table[t, case, n, 0] < 0:
                                break
                            row = f_start[k] + n_faces[k]
                            for v in range(3):
                                e = table[t, case, n, v]
                                ax, ay, az, d = (
                                    x + edges[e, 0],
                                    y + edges[e, 1],
                                    edges[e, 2],
                                    edges[e, 3],
                                )
                                if d < 3:
                                    parity = (g + az) & 1
                                    valid = previous[k] if az == 0 else current[k]
                                    vid = plane_ids[parity, k, ay, ax, d]
                                else:
                                    valid = current[k]
                                    vid = between_ids[k, ay, ax, d - 3]
                                if vid < valid:
                                    vid = state[0, k]
                                    state[0, k] += 1
                                    if d < 3:
                                        plane_ids[parity, k, ay, ax, d] = vid
                                    else:
                                        between_ids[k, ay, ax, d - 3] = vid
                                    bx = ax + DIRECTIONS_NB[d, 0]
                                    by = ay + DIRECTIONS_NB[d, 1]
                                    bz = z + az + DIRECTIONS_NB[d, 2]
                                    va = _node_value(field, k, z + az, ay, ax)
                                    vb = _node_value(field, k, bz, by, bx)
                                    pa = (
                                        origin[0] + step[0] * ax,
                                        origin[1] + step[1] * ay,
                                        origin[2] + step[2] * (g + az),
                                    )
                                    pb = (
                                        origin[0] + step[0] * bx,
                                        origin[1] + step[1] * by,
                                        origin[2] + step[2] * (g + bz - z),
                                    )
                                    fa = _near_face(field, z + az, ay, ax)
                                    fb = _near_face(field, bz, by, bx)
                                    share, on_face = va / (va - vb), -1
                                    if (
                                        fa >= 0
                                        and fa == fb
                                        and _foot_inside(field, fa, z + az, ay, ax, pa)
                                        and _foot_inside(field, fb, bz, by, bx, pb)
                                    ):
                                        # one face, its plane at both nodes: the field is
                                        # linear along the edge (the feet are an affine
                                        # map of the points), the linear share exact
                                        on_face = fa
                                    elif fa >= 0 and fb >= 0 and depth[k, fa] == depth[k, fb]:
                                        # (nodes of faces at two depths: the field jumps
                                        # between them, and the linear share stays)
                                        share, on_face = edge_crossing(
                                            field, k, pa, pb, fa, fb, va, vb, scratch
                                        )
                                    share = min(max(share, EDGE_MARGIN), 1.0 - EDGE_MARGIN)
                                    v_row = v_start[k] + made[k]
                                    made[k] += 1
                                    vertices[v_row, 0] = origin[0] + step[0] * (
                                        ax + share * (bx - ax)
                                    )
                                    vertices[v_row, 1] = origin[1] + step[1] * (
                                        ay + share * (by - ay)
                                    )
                                    vertices[v_row, 2] = origin[2] + step[2] * (
                                        g + az + share * (bz - z - az)
                                    )
                                    vertex_face[v_row] = on_face
                                faces[row, v] = vid
                            n_faces[k] += 1
        state[1] = current
    return made
