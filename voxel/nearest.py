"""Exact nearest points on a triangle mesh for many query points.

Candidates come from a k-d tree on face centroids; every candidate's exact point-triangle
distance is computed (Ericson's region test) and the smallest wins. The answer is proven
exact when the best distance is at most the k-th candidate's centroid distance minus the
largest centroid-to-corner distance (no other face can be closer); points that fail this
check are answered again with every face whose centroid lies within that safe radius.

References
----------
.. [1] C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, section 5.1.5.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

#: Query points handled at once (bounds temporary memory: about 2 kB per point).
POINTS_PER_CHUNK = 65_536


class Nearest(NamedTuple):
    """Nearest surface points of ``N`` query points.

    Attributes
    ----------
    face_ids : (N,) int64
        Face holding the nearest point.
    barycentric : (N, 3) float64
        Barycentric coordinates of the nearest point in that face (rows sum to 1).
    distance_mm : (N,) float64, mm
        Unsigned distance to the surface.
    """

    face_ids: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    distance_mm: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SurfaceIndex:
    """A triangle mesh prepared for nearest-point queries.

    Parameters
    ----------
    triangles : (F, 3, 3) float64, mm
        Corner positions.
    tree : cKDTree
        Tree over face centroids.
    reach_mm : float, mm
        Largest distance from a face centroid to one of its corners.
    """

    triangles: NDArray[np.float64]
    tree: cKDTree
    reach_mm: float

    @classmethod
    def build(cls, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> SurfaceIndex:
        """Index the faces of a mesh (``vertices (V, 3) float64`` mm, ``faces (F, 3) int64``)."""
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertices must be (V, 3), got shape {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise ValueError(f"faces must be (F, 3) with F >= 1, got shape {faces.shape}")
        triangles = np.ascontiguousarray(vertices[faces])
        centroids = triangles.mean(axis=1)
        reach = float(np.linalg.norm(triangles - centroids[:, None, :], axis=2).max())
        return cls(triangles, cKDTree(centroids), reach)


def nearest_on_surface(
    surface: SurfaceIndex, points_mm: NDArray[np.float64], *, n_candidates: int = 8
) -> Nearest:
    """Return the exact nearest surface point of each query point.

    Parameters
    ----------
    surface : SurfaceIndex
        The indexed mesh.
    points_mm : (N, 3) float64, mm
        Query points ``(x, y, z)``.
    n_candidates : int
        Nearest centroids tried first; more are tried only where needed for exactness.

    Returns
    -------
    Nearest
        Face id, barycentric coordinates and distance per point.

    Examples
    --------
    >>> tri = SurfaceIndex.build(np.eye(3), np.array([[0, 1, 2]]))
    >>> hit = nearest_on_surface(tri, np.array([[1.0, 1.0, 1.0]]))
    >>> hit.barycentric.round(3).tolist(), round(float(hit.distance_mm[0]), 4)
    ([[0.333, 0.333, 0.333]], 1.1547)
    """
    points = np.asarray(points_mm, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points_mm must be (N, 3), got shape {points.shape}")
    if n_candidates < 1:
        raise ValueError(f"n_candidates must be >= 1, got {n_candidates}")
    n = len(points)
    face_ids = np.zeros(n, dtype=np.int64)
    barycentric = np.zeros((n, 3), dtype=np.float64)
    distance = np.zeros(n, dtype=np.float64)
    for start in range(0, n, POINTS_PER_CHUNK):
        part = slice(start, start + POINTS_PER_CHUNK)
        face_ids[part], barycentric[part], distance[part] = _nearest_chunk(
            surface, points[part], n_candidates
        )
    return Nearest(face_ids, barycentric, distance)


def _nearest_chunk(
    surface: SurfaceIndex, points: NDArray[np.float64], n_candidates: int
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    n_faces = len(surface.triangles)
    k = min(n_candidates, n_faces)
    centroid_distance, candidates = surface.tree.query(points, k=k, workers=-1)
    candidates = np.asarray(candidates, dtype=np.int64).reshape(len(points), k)
    centroid_distance = np.asarray(centroid_distance).reshape(len(points), k)
    owner = np.repeat(np.arange(len(points)), k)
    faces, bary, dist = _best_per_owner(surface, points, owner, candidates.ravel(), len(points))
    if k < n_faces:
        unsure = np.flatnonzero(dist > centroid_distance[:, -1] - surface.reach_mm)
        if len(unsure):
            radius = dist[unsure] + surface.reach_mm
            lists = surface.tree.query_ball_point(points[unsure], radius, workers=-1)
            sizes = np.fromiter((len(item) for item in lists), dtype=np.int64, count=len(lists))
            flat = np.concatenate([np.asarray(item, dtype=np.int64) for item in lists])
            owner = np.repeat(np.arange(len(unsure)), sizes)
            redo = _best_per_owner(surface, points[unsure], owner, flat, len(unsure))
            faces[unsure], bary[unsure], dist[unsure] = redo
    return faces, bary, dist


def _best_per_owner(
    surface: SurfaceIndex,
    points: NDArray[np.float64],
    owner: NDArray[np.int64],
    candidate: NDArray[np.int64],
    n_owners: int,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Return, per owner point, the candidate face with the smallest exact distance."""
    query = points[owner]
    bary = closest_barycentric(query, surface.triangles[candidate])
    closest = np.einsum("nc,nck->nk", bary, surface.triangles[candidate])
    dist = np.linalg.norm(query - closest, axis=1)
    order = np.lexsort((candidate, dist, owner))
    first = order[np.r_[0, np.flatnonzero(np.diff(owner[order])) + 1]]
    if len(first) != n_owners:  # pragma: no cover - every owner has a candidate
        raise RuntimeError("a query point had no candidate face")
    return candidate[first], bary[first], dist[first]


def closest_barycentric(
    points: NDArray[np.float64], triangles: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return barycentric coordinates of the closest point of each triangle to each point.

    Parameters
    ----------
    points : (N, 3) float64
        Query points.
    triangles : (N, 3, 3) float64
        One triangle per point, corners ``a, b, c``.

    Returns
    -------
    (N, 3) float64
        Weights of ``a, b, c`` (non-negative, rows sum to 1).
    """
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, ac = b - a, c - a

    def dot(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        product: NDArray[np.float64] = np.einsum("nk,nk->n", u, v)
        return product

    ap, bp, cp = points - a, points - b, points - c
    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        total = va + vb + vc
        v_in, w_in = vb / total, vc / total
        v_ab = d1 / (d1 - d3)
        w_ac = d2 / (d2 - d6)
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    result: NDArray[np.float64] = np.stack([1.0 - v_in - w_in, v_in, w_in], axis=1)
    zeros = np.zeros_like(d1)
    # Regions from lowest to highest priority; later assignments win (Ericson's order).
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), (zeros, 1.0 - w_bc, w_bc)),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), (1.0 - w_ac, zeros, w_ac)),
        ((d6 >= 0) & (d5 <= d6), (zeros, zeros, zeros + 1.0)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), (1.0 - v_ab, v_ab, zeros)),
        ((d3 >= 0) & (d4 <= d3), (zeros, zeros + 1.0, zeros)),
        ((d1 <= 0) & (d2 <= 0), (zeros + 1.0, zeros, zeros)),
    ]
    for mask, weights in regions:
        result[mask] = np.stack(weights, axis=1)[mask]
    bad = ~np.all(np.isfinite(result), axis=1)
    result[bad] = (1.0, 0.0, 0.0)  # degenerate triangle with no region: any corner
    return result
