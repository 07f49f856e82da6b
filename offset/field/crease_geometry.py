"""Where the offset planes of a layer meet: the lines and corners its creases follow.

The kernels of :mod:`shellvox.offset.field.creases`. A vertex of a marched layer surface
that lies on its face's offset plane is labelled with the face (:func:`plane_labels`);
two faces' planes meet in a line (:func:`line_point`), three in a corner
(:func:`corner_point`). An edge between vertices on two planes, each behind the other's
plane (a convex crease), crosses their line where its offsets from the two planes are
equal: its crease point (:func:`edge_crease_points`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

#: Smallest move (mm) of a crease point from its edge for the edge to be split.
MIN_MOVE_MM = 1e-3

#: Largest distance (mm) of a vertex from its face's offset plane to count as on it (a
#: vertex held ``EDGE_MARGIN`` of its edge off a node lies up to 1.7e-7 mm off).
ON_PLANE_MM = 1e-6

#: Two planes whose unit normals' cross product is shorter than this are parallel.
PARALLEL = 1e-6

#: Smallest angle (degrees) between two faces' normals for their planes' line to be a
#: crease put back: a smaller bend (a scan's neighbouring faces) the grid rounds by less
#: than ``(step / 2) * sin(angle / 2)``.
FEATURE_DEG = 30.0

#: Its cosine.
FEATURE_COS = float(np.cos(np.radians(FEATURE_DEG)))


@kernel
def plane_labels(
    vertices: NDArray[np.float64],
    vertex_face: NDArray[np.int32],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Every vertex's face where it lies within ``ON_PLANE_MM`` of its offset plane, else -1."""
    label = np.full(len(vertices), -1, dtype=np.int64)
    for i in range(len(vertices)):
        f = vertex_face[i]
        if f >= 0 and abs(plane_offset(normals, plane_levels, f, vertices[i])) <= ON_PLANE_MM:
            label[i] = f
    return label


@kernel
def crease_candidates(
    faces: NDArray[np.int64], label: NDArray[np.int64], normals: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Triangles with an edge between vertices on two planes that are not parallel."""
    out = np.zeros(len(faces), dtype=np.bool_)
    for t in range(len(faces)):
        for j in range(3):
            a = label[faces[t, j]]
            b = label[faces[t, (j + 1) % 3]]
            if a < 0 or b < 0 or a == b:
                continue
            if is_crease(normals, a, b):
                out[t] = True
                break
    return out


@kernel(inline="always")
def is_crease(normals: NDArray[np.float64], a: int, b: int) -> bool:
    """Return whether two faces' normals are ``FEATURE_DEG`` or more apart."""
    dot = normals[a, 0] * normals[b, 0] + normals[a, 1] * normals[b, 1]
    return bool(dot + normals[a, 2] * normals[b, 2] < FEATURE_COS)


@kernel(inline="always")
def plane_offset(
    normals: NDArray[np.float64], levels: NDArray[np.float64], f: int, p: NDArray[np.float64]
) -> float:
    """Signed distance of ``p`` from face ``f``'s offset plane (positive outward)."""
    return float(normals[f, 0] * p[0] + normals[f, 1] * p[1] + normals[f, 2] * p[2] - levels[f])


@kernel
def edge_crease_points(
    ends: NDArray[np.int64],
    vertices: NDArray[np.float64],
    pairs: NDArray[np.int64],
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Return the crease point of every edge for each plane pair, and whether it is one.

    `pairs` is ``(E, C, 2)``, the first plane the first end's. A point is one where the
    planes are not parallel, each end lies behind the other's plane, and the move from
    the edge is at least ``MIN_MOVE_MM`` and at most the edge's length.
    """
    n, n_combos = pairs.shape[0], pairs.shape[1]
    point = np.zeros((n, n_combos, 3))
    valid = np.zeros((n, n_combos), dtype=np.bool_)
    p = np.zeros(3)
    for e in range(n):
        u, w = ends[e, 0], ends[e, 1]
        for combo in range(n_combos):
            fa, fb = pairs[e, combo, 0], pairs[e, combo, 1]
            if fa < 0 or fb < 0 or fa == fb or not is_crease(normals, fa, fb):
                continue
            # Each end behind the other's plane: a convex crease, the surface the lower plane.
            gu = plane_offset(normals, levels, fb, vertices[u])
            gw = plane_offset(normals, levels, fa, vertices[w])
            if not (gu < 0.0 and gw < 0.0):
                continue
            # Along the edge offset(A) - offset(B) runs from -gu > 0 to gw < 0.
            s = -gu / (-gu - gw)
            for i in range(3):
                p[i] = vertices[u, i] + s * (vertices[w, i] - vertices[u, i])
            # The nearest point of the planes' line.
            line_point(normals, levels, fa, fb, p, point[e, combo])
            move2 = 0.0
            length2 = 0.0
            for i in range(3):
                move2 += (point[e, combo, i] - p[i]) ** 2
                length2 += (vertices[w, i] - vertices[u, i]) ** 2
            valid[e, combo] = MIN_MOVE_MM * MIN_MOVE_MM <= move2 <= length2
    return point, valid


@kernel
def edge_corner_points(
    ends: NDArray[np.int64],
    vertices: NDArray[np.float64],
    triples: NDArray[np.int64],
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Return the corner of three planes for every edge, and whether it is one.

    It is one where the planes are not nearly parallel and the point lies within two
    edge lengths of the edge.
    """
    n = len(ends)
    point = np.zeros((n, 3))
    valid = np.zeros(n, dtype=np.bool_)
    for e in range(n):
        if not corner_point(normals, levels, triples[e, 0], triples[e, 1], triples[e, 2], point[e]):
            continue
        u, w = vertices[ends[e, 0]], vertices[ends[e, 1]]
        length2 = 0.0
        along = 0.0
        for i in range(3):
            length2 += (w[i] - u[i]) ** 2
            along += (point[e, i] - u[i]) * (w[i] - u[i])
        s = min(1.0, max(0.0, along / length2)) if length2 > 0.0 else 0.0
        d2 = 0.0
        for i in range(3):
            d2 += (point[e, i] - (u[i] + s * (w[i] - u[i]))) ** 2
        valid[e] = d2 <= 4.0 * length2  # within two edge lengths
    return point, valid


@kernel(inline="always")
def line_point(
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
    fa: int,
    fb: int,
    p: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """Write the point of the line of two offset planes nearest to ``p`` into `out`."""
    ra = -plane_offset(normals, levels, fa, p)
    rb = -plane_offset(normals, levels, fb, p)
    c = normals[fa, 0] * normals[fb, 0] + normals[fa, 1] * normals[fb, 1]
    c += normals[fa, 2] * normals[fb, 2]
    det = 1.0 - c * c
    alpha = (ra - c * rb) / det
    beta = (rb - c * ra) / det
    for i in range(3):
        out[i] = p[i] + alpha * normals[fa, i] + beta * normals[fb, i]


@kernel
def triangle_corners(
    tri: NDArray[np.int64],
    vertices: NDArray[np.float64],
    planes: NDArray[np.int64],
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_]]:
    """Return the common point of the planes of every triangle's corners, and whether.

    It is one where the corners lie on three planes, none of which holds all three, not
    nearly parallel, and the point is no farther from every corner than the triangle's
    longest side. Also returns the three planes ((T, 3), -1 for none).
    """
    n_tri = len(tri)
    corner = np.zeros((n_tri, 3))
    corner_planes = np.full((n_tri, 3), -1, dtype=np.int64)
    ok = np.zeros(n_tri, dtype=np.bool_)
    for t in range(n_tri):
        # the distinct planes of the corners; none may hold all three corners
        found = np.full(9, -1, dtype=np.int64)
        n_found = 0
        shared = False
        for j in range(3):
            for m in range(3):
                f = planes[tri[t, j], m]
                if f < 0:
                    continue
                seen = False
                for q in range(n_found):
                    seen = seen or found[q] == f
                if not seen:
                    found[n_found] = f
                    n_found += 1
                    holds = 0
                    for jj in range(3):
                        row = planes[tri[t, jj]]
                        if row[0] == f or row[1] == f or row[2] == f:
                            holds += 1
                    shared = shared or holds == 3
        if n_found != 3 or shared:
            continue
        fa, fb, fc = found[0], found[1], found[2]
        if not corner_point(normals, levels, fa, fb, fc, corner[t]):
            continue
        corner_planes[t, 0], corner_planes[t, 1], corner_planes[t, 2] = fa, fb, fc
        p = corner[t]
        reach2 = 0.0
        for j in range(3):
            reach2 = max(reach2, np.sum((vertices[tri[t, j]] - vertices[tri[t, (j + 1) % 3]]) ** 2))
        near = True
        for j in range(3):
            if np.sum((vertices[tri[t, j]] - p) ** 2) > reach2:
                near = False
        ok[t] = near
    return corner, corner_planes, ok


@kernel
def corner_point(
    normals: NDArray[np.float64],
    levels: NDArray[np.float64],
    fa: int,
    fb: int,
    fc: int,
    out: NDArray[np.float64],
) -> bool:
    """Write the common point of three faces' offset planes into `out` (Cramer's rule).

    Returns False where the planes are nearly parallel or not three.
    """
    if fa < 0 or fb < 0 or fc < 0 or fa in (fb, fc) or fb == fc:
        return False
    a, b, c = normals[fa], normals[fb], normals[fc]
    bc0 = b[1] * c[2] - b[2] * c[1]
    bc1 = b[2] * c[0] - b[0] * c[2]
    bc2 = b[0] * c[1] - b[1] * c[0]
    det = a[0] * bc0 + a[1] * bc1 + a[2] * bc2
    if abs(det) < 1e-3:
        return False
    ca0 = c[1] * a[2] - c[2] * a[1]
    ca1 = c[2] * a[0] - c[0] * a[2]
    ca2 = c[0] * a[1] - c[1] * a[0]
    ab0 = a[1] * b[2] - a[2] * b[1]
    ab1 = a[2] * b[0] - a[0] * b[2]
    ab2 = a[0] * b[1] - a[1] * b[0]
    la, lb, lc = levels[fa], levels[fb], levels[fc]
    out[0] = (la * bc0 + lb * ca0 + lc * ab0) / det
    out[1] = (la * bc1 + lb * ca1 + lc * ab1) / det
    out[2] = (la * bc2 + lb * ca2 + lc * ab2) / det
    return True
