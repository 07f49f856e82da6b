"""Edits of a marched layer surface that put its creases back: moves and splits.

The kernels of :mod:`shellvox.offset.field.creases`: the vertices next to a crease move
onto it (:func:`snap_targets`, :func:`apply_snaps`) and the triangles across one are split
at their edges' crease points and their corner points (:func:`split_triangles`), each
move and split kept only where no triangle turns over.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shellvox.offset.field.crease_geometry import (
    corner_point,
    is_crease,
    line_point,
    plane_offset,
)
from shellvox.voxel._compiled import kernel

#: Largest move of a vertex onto a crease, as a share of the edge across it.
SNAP_SHARE = 0.25

#: Smallest share of its area a triangle keeps when a vertex moves onto a crease.
KEEP_AREA = 0.1


@kernel
def snap_targets(
    tri: NDArray[np.int64],
    points: NDArray[np.float64],
    planes: NDArray[np.int64],
    stuck: NDArray[np.bool_],
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Return every vertex's nearest crease point, the plane it adds, and the move.

    Only points within ``SNAP_SHARE`` of an edge to a vertex on another plane (a convex
    crease) count; the move is infinite where there is none.

    A vertex on one plane goes to the line of its plane and the other; a vertex on two
    (a crease) to the point of its two planes and the other (a corner).
    """
    n = len(points)
    target = np.zeros((n, 3))
    other = np.full(n, -1, dtype=np.int64)
    move = np.full(n, np.inf)
    candidate = np.zeros(3)
    for t in range(len(tri)):
        for j in range(6):
            u = tri[t, j % 3]
            w = tri[t, (j % 3 + 1 + j // 3) % 3]
            fa, fa2 = planes[u, 0], planes[u, 1]
            if fa < 0 or planes[u, 2] >= 0:
                continue  # on no plane, or on three already
            for mw in range(3):
                fb = planes[w, mw]
                if fb < 0 or fb in (fa, fa2):
                    continue
                if not is_crease(normals, fa, fb):
                    continue
                # each end behind the other's plane (a convex crease)
                if not (
                    plane_offset(normals, levels, fb, points[u]) < 0.0
                    and plane_offset(normals, levels, fa, points[w]) < 0.0
                ):
                    continue
                if fa2 >= 0:
                    if not corner_point(normals, levels, fa, fa2, fb, candidate):
                        continue
                else:
                    line_point(normals, levels, fa, fb, points[u], candidate)
                d2 = 0.0
                length2 = 0.0
                for i in range(3):
                    d2 += (candidate[i] - points[u, i]) ** 2
                    length2 += (points[w, i] - points[u, i]) ** 2
                share = 1.0 if stuck[u] else SNAP_SHARE
                if d2 <= share * share * length2 and d2 < move[u] * move[u]:
                    move[u] = np.sqrt(d2)
                    other[u] = fb
                    for i in range(3):
                        target[u, i] = candidate[i]
    return target, other, move


@kernel
def apply_snaps(
    tri: NDArray[np.int64],
    points: NDArray[np.float64],
    planes: NDArray[np.int64],
    order: NDArray[np.int64],
    target: NDArray[np.float64],
    other: NDArray[np.int64],
    around: NDArray[np.int64],
    start: NDArray[np.int64],
    normals: NDArray[np.float64],
) -> int:
    """Move the vertices in `order` to their targets where allowed (see :func:`_snap`)."""
    blocked = np.zeros(len(points), dtype=np.bool_)
    moved = 0
    old = np.zeros(3)
    for u in order:
        if blocked[u]:
            continue
        fine = True
        for i in range(3):
            old[i] = points[u, i]
        for r in range(start[u], start[u + 1]):
            t = around[r]
            a, b, c = points[tri[t, 0]], points[tri[t, 1]], points[tri[t, 2]]
            n0, n1, n2 = _normal(a, b, c)
            for i in range(3):
                points[u, i] = target[u, i]
            m0, m1, m2 = _normal(points[tri[t, 0]], points[tri[t, 1]], points[tri[t, 2]])
            for i in range(3):
                points[u, i] = old[i]
            before = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            after = np.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
            if m0 * n0 + m1 * n1 + m2 * n2 <= 0.0 or after < KEEP_AREA * before:
                fine = False
                break
        if not fine:
            continue
        for i in range(3):
            points[u, i] = target[u, i]
        planes[u, 2 if planes[u, 1] >= 0 else 1] = other[u]
        moved += 1
        for r in range(start[u], start[u + 1]):
            t = around[r]
            for j in range(3):
                blocked[tri[t, j]] = True
    return moved


@kernel(inline="always")
def _normal(
    p: NDArray[np.float64], q: NDArray[np.float64], r: NDArray[np.float64]
) -> tuple[float, float, float]:
    """Unnormalised normal of triangle ``p q r``."""
    a0, a1, a2 = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    b0, b1, b2 = r[0] - p[0], r[1] - p[1], r[2] - p[2]
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@kernel
def split_triangles(
    tri: NDArray[np.int64],
    edge_of: NDArray[np.int64],
    point: NDArray[np.float64],
    ok: NDArray[np.bool_],
    corner: NDArray[np.float64],
    corner_ok: NDArray[np.bool_],
    vertices: NDArray[np.float64],
    n_vertices: int,
    planes: NDArray[np.int64],
    edge_planes: NDArray[np.int64],
    corner_planes: NDArray[np.int64],
    normals: NDArray[np.float64],
    rep: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    """Split the candidate triangles at their kept crease points.

    Returns the new triangles of the triangles with a split (vertex ids: the surface's,
    then ``n_vertices + edge``, then ``n_vertices + n_edges + triangle`` for a corner
    point), which triangles got their corner point, and the triangles whose new triangles
    turn over: a normal 90 degrees or more from the outward normal of the plane its three
    corners lie on, or from the parent's where they lie on none. Edges whose crease
    points were merged share the point ``rep[edge]``; a triangle split on two edges whose
    corner between them would turn over asks for its two points to be merged (the last
    array) when they lie on one line.
    """
    n_tri = len(tri)
    n_edges = len(point)
    out = np.zeros((6 * n_tri, 3), dtype=np.int64)
    has_corner = np.zeros(n_tri, dtype=np.bool_)
    bad = np.zeros(n_tri, dtype=np.bool_)
    merge = np.zeros(n_tri, dtype=np.bool_)
    all_points = np.zeros((7, 3))
    ids = np.zeros(7, dtype=np.int64)
    on = np.full((7, 3), -1, dtype=np.int64)  # the planes of every local point
    q = np.zeros((3, 3))
    locals_ = np.zeros(3, dtype=np.int64)
    ring = np.zeros(6, dtype=np.int64)
    made = 0
    for t in range(n_tri):
        n_split = 0
        for j in range(3):
            if ok[edge_of[t, j]]:
                n_split += 1
        if n_split == 0 and not corner_ok[t]:
            continue
        for j in range(3):
            ids[j] = tri[t, j]
            ids[3 + j] = n_vertices + rep[edge_of[t, j]]
            for i in range(3):
                all_points[j, i] = vertices[tri[t, j], i]
                all_points[3 + j, i] = point[rep[edge_of[t, j]], i]
        ids[6] = n_vertices + n_edges + t
        for i in range(3):
            all_points[6, i] = corner[t, i]
        for j in range(3):
            for m in range(3):
                on[j, m] = planes[tri[t, j], m]
                on[3 + j, m] = edge_planes[rep[edge_of[t, j]], m]
                on[6, m] = corner_planes[t, m]
        start = made
        if corner_ok[t]:
            # a fan from the corner point over the corners and the edges' points
            has_corner[t] = True
            n_ring = 0
            for j in range(3):
                ring[n_ring] = j
                n_ring += 1
                if ok[edge_of[t, j]]:
                    ring[n_ring] = 3 + j
                    n_ring += 1
            for r in range(n_ring):
                nxt = ring[(r + 1) % n_ring]
                out[made, 0], out[made, 1], out[made, 2] = ids[ring[r]], ids[nxt], ids[6]
                made += 1
        elif n_split == 1:
            j = 0
            while not ok[edge_of[t, j]]:
                j += 1
            # edge j runs from corner j to corner j + 1
            a, b, c = j, (j + 1) % 3, (j + 2) % 3
            out[made, 0], out[made, 1], out[made, 2] = ids[a], ids[3 + j], ids[c]
            out[made + 1, 0], out[made + 1, 1], out[made + 1, 2] = ids[3 + j], ids[b], ids[c]
            made += 2
        elif n_split == 2:
            j = 0
            while ok[edge_of[t, j]]:
                j += 1
            # edge j (corner j to j + 1) is whole; the lone corner is j + 2
            a, b, c = j, (j + 1) % 3, (j + 2) % 3
            s_bc, s_ca = 3 + b, 3 + c  # edge b runs b -> c, edge c runs c -> a
            if ids[s_bc] == ids[s_ca]:  # merged: the corner's triangle is gone
                out[made, 0], out[made, 1], out[made, 2] = ids[a], ids[b], ids[s_bc]
                made += 1
                start_check = made - 1
                n0, n1, n2 = _normal(all_points[0], all_points[1], all_points[2])
                m0, m1, m2 = _normal(all_points[a], all_points[b], all_points[s_bc])
                if m0 * n0 + m1 * n1 + m2 * n2 <= 0.0 and start_check >= 0:
                    bad[t] = True
                continue
            m0, m1, m2 = _normal(all_points[c], all_points[s_ca], all_points[s_bc])
            common = _common_plane(on, c, s_ca, s_bc)
            if common >= 0 and (
                m0 * normals[common, 0] + m1 * normals[common, 1] + m2 * normals[common, 2] <= 0.0
            ):
                pa, pb = edge_planes[rep[edge_of[t, b]]], edge_planes[rep[edge_of[t, c]]]
                if (pa[0] == pb[0] and pa[1] == pb[1]) or (pa[0] == pb[1] and pa[1] == pb[0]):
                    merge[t] = True
            out[made, 0], out[made, 1], out[made, 2] = ids[c], ids[s_ca], ids[s_bc]
            made += 1
            # the quad a, b, s_bc, s_ca: the diagonal with the larger smallest angle
            if _min_sin(all_points, a, b, s_bc, s_ca) >= _min_sin(all_points, b, s_bc, s_ca, a):
                out[made, 0], out[made, 1], out[made, 2] = ids[a], ids[b], ids[s_bc]
                out[made + 1, 0], out[made + 1, 1], out[made + 1, 2] = ids[a], ids[s_bc], ids[s_ca]
            else:
                out[made, 0], out[made, 1], out[made, 2] = ids[b], ids[s_bc], ids[s_ca]
                out[made + 1, 0], out[made + 1, 1], out[made + 1, 2] = ids[b], ids[s_ca], ids[a]
            made += 2
        else:
            if ids[3] == ids[4] or ids[4] == ids[5] or ids[5] == ids[3]:
                bad[t] = True  # two of its points merged
                continue
            for j in range(3):
                prev = (j + 2) % 3
                out[made, 0], out[made, 1], out[made, 2] = ids[j], ids[3 + j], ids[3 + prev]
                made += 1
            out[made, 0], out[made, 1], out[made, 2] = ids[3], ids[4], ids[5]
            made += 1
        # every new triangle on the parent's side
        n0, n1, n2 = _normal(all_points[0], all_points[1], all_points[2])
        for r in range(start, made):
            for v in range(3):
                local = 0
                while ids[local] != out[r, v]:
                    local += 1
                locals_[v] = local
                for i in range(3):
                    q[v, i] = all_points[local, i]
            m0, m1, m2 = _normal(q[0], q[1], q[2])
            r0, r1, r2 = n0, n1, n2
            common = _common_plane(on, locals_[0], locals_[1], locals_[2])
            if common >= 0:
                r0, r1, r2 = normals[common, 0], normals[common, 1], normals[common, 2]
            if m0 * r0 + m1 * r1 + m2 * r2 <= 0.0:
                bad[t] = True
    return out[:made], has_corner, bad, merge


@kernel(inline="always")
def _common_plane(on: NDArray[np.int64], a: int, b: int, c: int) -> int:
    """Return a plane of point ``a`` that points ``b`` and ``c`` lie on too, -1 for none."""
    for m in range(3):
        f = on[a, m]
        if f < 0:
            continue
        in_b = on[b, 0] == f or on[b, 1] == f or on[b, 2] == f
        in_c = on[c, 0] == f or on[c, 1] == f or on[c, 2] == f
        if in_b and in_c:
            return int(f)
    return -1


@kernel(inline="always")
def _min_sin(points: NDArray[np.float64], a: int, b: int, c: int, d: int) -> float:
    """Smallest sine of an angle over triangles ``a b c`` and ``a c d``."""
    return min(_tri_min_sin(points, a, b, c), _tri_min_sin(points, a, c, d))


@kernel(inline="always")
def _tri_min_sin(points: NDArray[np.float64], a: int, b: int, c: int) -> float:
    """Twice the area over the product of the two longest sides (the smallest angle's sine)."""
    n0, n1, n2 = _normal(points[a], points[b], points[c])
    area2 = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    la = np.sqrt(np.sum((points[b] - points[c]) ** 2))
    lb = np.sqrt(np.sum((points[c] - points[a]) ** 2))
    lc = np.sqrt(np.sum((points[a] - points[b]) ** 2))
    product = la * lb * lc / min(la, lb, lc) if min(la, lb, lc) > 0.0 else 0.0
    return area2 / product if product > 0.0 else 0.0
