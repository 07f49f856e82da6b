"""Half-space bounds of the Voronoi regions of a triangle mesh's faces, edges and vertices.

A point's nearest surface point lies in the interior of a face, of an edge, or at a
vertex, and the point then lies in that feature's region:

* **face** ``f``: the prism over the triangle along its normal (the three planes through
  its edges that contain the normal);
* **edge** ``a b``: the slab ``0 <= (p - a) . (b - a) <= |b - a|^2`` and, for each face
  ``f`` on the edge, the side of the plane through the edge, perpendicular to ``f``,
  away from ``f``: ``(p - a) . m_f <= 0``, with ``m_f`` the in-face normal of the edge
  pointing into ``f``;
* **vertex** ``v``: ``(p - v) . (w - v) <= 0`` for every neighbour ``w`` of ``v``.

These are necessary conditions (Ericson's region tests [1]_ of each incident face), so
each region holds the true one whatever the mesh: open, non-manifold, with degenerate
faces (a zero-area face has no prism; its edges and vertices still have regions). Every
bound is loosened by ``EPSILON`` of the model's size so that rounding never drops a
point on a shared boundary. :mod:`shellvox.voxel.geometry._distance_scan` scans each region into the
voxels within reach and tests only the faces of that feature (the region's ``tests``).

References
----------
.. [1] C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, section 5.1.5.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

#: Loosening of every bound, relative to the model's largest coordinate (plus 1 mm).
EPSILON = 1e-9

FACE, EDGE, VERTEX = 0, 1, 2


class VoronoiRegions(NamedTuple):
    """Bounds of the region of every face, edge and vertex of a mesh (the scan's input).

    Attributes
    ----------
    kind : (N,) int8
        ``FACE`` (0), ``EDGE`` (1) or ``VERTEX`` (2), faces first.
    anchor : (N, 2) int64
        The face id and -1, the edge's vertices ``(a, b)``, or the vertex twice.
    bounds_ptr : (N + 1,) int64
        Region ``n`` is bounded by ``bounds[bounds_ptr[n]:bounds_ptr[n + 1]]``.
    bounds : (C, 4) float64
        Half-spaces ``g . p <= h`` as rows ``(gx, gy, gz, h)``, ``g`` unit, ``h`` mm.
    tests_ptr : (N + 1,) int64
        Region ``n`` tests the faces ``tests[tests_ptr[n]:tests_ptr[n + 1]]``.
    tests : (T,) int64
        Faces holding the feature, increasing within a region.
    normals : (F, 3) float64
        Unit face normals (zero for a zero-area face).
    spread : (N, 6) float64
        Extent of the region's directions from its feature: every ``p`` of region ``n``
        within ``r`` of the feature lies in the feature's box grown by
        ``r * spread[n, :3]`` (low, negative) and ``r * spread[n, 3:]`` (high).
    """

    kind: NDArray[np.int8]
    anchor: NDArray[np.int64]
    bounds_ptr: NDArray[np.int64]
    bounds: NDArray[np.float64]
    tests_ptr: NDArray[np.int64]
    tests: NDArray[np.int64]
    normals: NDArray[np.float64]
    spread: NDArray[np.float64]


def voronoi_regions(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> VoronoiRegions:
    """Return the region bounds of the faces, edges and vertices of a mesh.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
        Vertex positions.
    faces : (F, 3) int64
        Triangles (any orientation; open and non-manifold meshes are fine).

    Examples
    --------
    >>> regions = voronoi_regions(np.eye(3), np.array([[0, 1, 2]]))
    >>> np.bincount(regions.kind).tolist()  # 1 face, 3 edges, 3 vertices
    [1, 3, 3]
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    eps = EPSILON * (1.0 + float(np.abs(vertices).max(initial=0.0)))
    corners = vertices[faces]  # (F, 3, 3)
    normals = _unit(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    # half-edge e of face f runs from corner e to corner e + 1; m points into f
    start = corners
    stop = np.roll(corners, -1, axis=1)
    inward = _unit(np.cross(normals[:, None, :], stop - start))  # (F, 3, 3)
    proper = np.flatnonzero(np.any(normals != 0, axis=1))

    # faces: -m . p <= -m . P + eps for the three edges
    face_g = -inward[proper]
    face_h = np.einsum("fek,fek->fe", face_g, start[proper]) + eps
    face_bounds = np.concatenate([face_g, face_h[..., None]], axis=2).reshape(-1, 4)

    # edges: unique undirected edges with the half-edges on them
    half_from = faces.ravel()
    half_to = np.roll(faces, -1, axis=1).ravel()
    low, high = np.minimum(half_from, half_to), np.maximum(half_from, half_to)
    order = np.lexsort((high, low))
    key_low, key_high = low[order], high[order]
    first = np.flatnonzero(
        np.r_[True, (key_low[1:] != key_low[:-1]) | (key_high[1:] != key_high[:-1])]
    )
    sizes = np.diff(np.r_[first, len(order)])
    edge_a, edge_b = key_low[first], key_high[first]
    edge_faces = order // 3  # half-edge -> face, grouped by edge
    tangent = _unit(vertices[edge_b] - vertices[edge_a])
    slab = np.concatenate(
        [
            np.concatenate(
                [-tangent, (-tangent * vertices[edge_a]).sum(axis=1, keepdims=True) + eps], axis=1
            )[:, None],
            np.concatenate(
                [tangent, (tangent * vertices[edge_b]).sum(axis=1, keepdims=True) + eps], axis=1
            )[:, None],
        ],
        axis=1,
    )  # (E, 2, 4)
    side_g = inward.reshape(-1, 3)[order]
    side_h = (side_g * vertices[key_low]).sum(axis=1) + eps
    side = np.concatenate([side_g, side_h[:, None]], axis=1)  # (H, 4), grouped by edge
    edge_owner = np.repeat(np.arange(len(first)), sizes)
    edge_rows = np.concatenate([slab.reshape(-1, 4), side])
    edge_rank = np.concatenate([np.repeat(np.arange(len(first)), 2), edge_owner])
    edge_bounds = edge_rows[np.argsort(edge_rank, kind="stable")]
    edge_counts = 2 + sizes
    edge_tests = _sorted_groups(edge_faces, edge_owner)

    # vertices: (p - v) . unit(w - v) <= eps for each neighbour w
    ends = np.concatenate([edge_a, edge_b])
    others = np.concatenate([edge_b, edge_a])
    by_vertex = np.argsort(ends, kind="stable")
    ends, others = ends[by_vertex], others[by_vertex]
    direction = _unit(vertices[others] - vertices[ends])
    vertex_h = (direction * vertices[ends]).sum(axis=1) + eps
    vertex_bounds = np.concatenate([direction, vertex_h[:, None]], axis=1)
    used, vertex_counts = np.unique(ends, return_counts=True)
    incident_vertex = faces.ravel()
    incident_face = np.repeat(np.arange(len(faces)), 3)
    keep = np.isin(incident_vertex, used)
    rank = np.searchsorted(used, incident_vertex[keep])
    vertex_tests = _sorted_groups(incident_face[keep], rank)

    kind = np.concatenate(
        [
            np.full(len(proper), FACE, np.int8),
            np.full(len(first), EDGE, np.int8),
            np.full(len(used), VERTEX, np.int8),
        ]
    )
    anchor = np.concatenate(
        [
            np.stack([proper, np.full(len(proper), -1)], axis=1),
            np.stack([edge_a, edge_b], axis=1),
            np.stack([used, used], axis=1),
        ]
    ).astype(np.int64)
    counts = np.concatenate([np.full(len(proper), 3), edge_counts, vertex_counts])
    bounds = np.concatenate([face_bounds, edge_bounds, vertex_bounds])
    vertex_sizes = _group_sizes(rank, len(used))
    tests_per = np.concatenate([np.ones(len(proper), np.int64), sizes, vertex_sizes])
    tests = np.concatenate([proper, edge_tests, vertex_tests]).astype(np.int64)
    bounds_ptr = np.r_[0, np.cumsum(counts)].astype(np.int64)
    bounds = np.ascontiguousarray(bounds)
    spread = np.empty((len(kind), 6))
    n_faces = len(proper)
    spread[:n_faces, :3] = -np.abs(normals[proper])
    spread[:n_faces, 3:] = np.abs(normals[proper])
    _cone_spread(bounds_ptr, bounds, n_faces, spread)
    return VoronoiRegions(
        kind,
        anchor,
        bounds_ptr,
        bounds,
        np.r_[0, np.cumsum(tests_per)].astype(np.int64),
        tests,
        normals,
        spread,
    )


#: Regions with more bounds than this get the whole box of directions (their cone's
#: vertex enumeration would cost the cube of the count).
MAX_CONE_BOUNDS = 24


@kernel
def _cone_spread(
    bounds_ptr: NDArray[np.int64],
    bounds: NDArray[np.float64],
    first: int,
    spread: NDArray[np.float64],
) -> None:
    """Box of the directions ``{d : g . d <= 0 for the region's g, |d_k| <= 1}``.

    Regions ``first..N`` (edges and vertices): the bounds of their directions from the
    feature are the homogeneous parts of their half-spaces. The box is that of the
    vertices of this polytope (every triple of its planes, box faces included, whose
    point is feasible), and of ``d = 0``; it holds the unit ball's part of the cone.
    """
    planes = np.empty((MAX_CONE_BOUNDS + 6, 3))
    limit = np.empty(MAX_CONE_BOUNDS + 6)
    for n in range(first, len(bounds_ptr) - 1):
        count = bounds_ptr[n + 1] - bounds_ptr[n]
        if count > MAX_CONE_BOUNDS:
            for axis in range(3):
                spread[n, axis] = -1.0
                spread[n, 3 + axis] = 1.0
            continue
        for c in range(count):
            for axis in range(3):
                planes[c, axis] = bounds[bounds_ptr[n] + c, axis]
            limit[c] = 0.0
        for axis in range(3):
            for side in range(2):
                row = count + 2 * axis + side
                for other in range(3):
                    planes[row, other] = 0.0
                planes[row, axis] = 1.0 if side else -1.0
                limit[row] = 1.0
        total = count + 6
        low = np.zeros(3)
        high = np.zeros(3)
        for i in range(total):
            for j in range(i + 1, total):
                for k in range(j + 1, total):
                    a = planes[i]
                    b = planes[j]
                    c = planes[k]
                    bc0 = b[1] * c[2] - b[2] * c[1]
                    bc1 = b[2] * c[0] - b[0] * c[2]
                    bc2 = b[0] * c[1] - b[1] * c[0]
                    det = a[0] * bc0 + a[1] * bc1 + a[2] * bc2
                    if abs(det) < 1e-12:
                        continue
                    ca0 = c[1] * a[2] - c[2] * a[1]
                    ca1 = c[2] * a[0] - c[0] * a[2]
                    ca2 = c[0] * a[1] - c[1] * a[0]
                    ab0 = a[1] * b[2] - a[2] * b[1]
                    ab1 = a[2] * b[0] - a[0] * b[2]
                    ab2 = a[0] * b[1] - a[1] * b[0]
                    li, lj, lk = limit[i], limit[j], limit[k]
                    d0 = (li * bc0 + lj * ca0 + lk * ab0) / det
                    d1 = (li * bc1 + lj * ca1 + lk * ab1) / det
                    d2 = (li * bc2 + lj * ca2 + lk * ab2) / det
                    feasible = True
                    for q in range(total):
                        value = planes[q, 0] * d0 + planes[q, 1] * d1 + planes[q, 2] * d2
                        if value > limit[q] + 1e-9:
                            feasible = False
                            break
                    if feasible:
                        low[0] = min(low[0], d0)
                        low[1] = min(low[1], d1)
                        low[2] = min(low[2], d2)
                        high[0] = max(high[0], d0)
                        high[1] = max(high[1], d1)
                        high[2] = max(high[2], d2)
        for axis in range(3):
            spread[n, axis] = max(-1.0, low[axis] - 1e-9)
            spread[n, 3 + axis] = min(1.0, high[axis] + 1e-9)


def _unit(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return ``vectors (..., 3)`` scaled to unit length (zero ones stay zero)."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit: NDArray[np.float64] = np.where(length > 0, vectors / length, 0.0)
    return unit


def _sorted_groups(values: NDArray[np.int64], group: NDArray[np.int64]) -> NDArray[np.int64]:
    """Return ``values`` ordered by ``group``, then increasing within a group."""
    sorted_values: NDArray[np.int64] = values[np.lexsort((values, group))]
    return sorted_values


def _group_sizes(group: NDArray[np.int64], n_groups: int) -> NDArray[np.int64]:
    """Return the number of members of each of ``n_groups`` groups."""
    sizes: NDArray[np.int64] = np.bincount(group, minlength=n_groups).astype(np.int64)
    return sizes
