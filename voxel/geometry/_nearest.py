"""Point queries on a triangle mesh: exact nearest points and generalised winding numbers.

The one wrapper of libigl's queries in shellvox (:mod:`offset` uses it too). The nearest-
point search runs in libigl's axis-aligned bounding-box tree [1]_ (compiled, exact point-
triangle distances, threaded over the query points); the barycentric coordinates of the
answer are then recomputed in numpy with Ericson's Voronoi-region test [2]_, so the
returned point, its face and its distance are mutually consistent to rounding.
:func:`winding_numbers` is libigl's exact generalised winding number [3]_ (solid angles
summed over the faces, hierarchically). Inside tests on a whole voxel grid use
:mod:`shellvox.voxel.geometry._winding` instead (signed crossings along grid rows, exact and much
faster).

References
----------
.. [1] A. Jacobson et al., *libigl: a simple C++ geometry processing library*,
   https://libigl.github.io (``igl::AABB::squared_distance``).
.. [2] C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, section 5.1.5.
.. [3] A. Jacobson, L. Kavan, O. Sorkine-Hornung, "Robust inside-outside segmentation
   using generalized winding numbers", ACM TOG 32(4), 2013.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import igl
import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.geometry._voronoi import VoronoiRegions, voronoi_regions

#: Query points handled at once (bounds temporary memory: about 150 bytes per point).
POINTS_PER_CHUNK = 1 << 20


class Nearest(NamedTuple):
    """Nearest surface points of ``N`` query points.

    Attributes
    ----------
    face_ids : (N,) int64
        Face holding the nearest point (one of them where several tie).
    barycentric : (N, 3) float64
        Barycentric coordinates of the nearest point in that face (non-negative, rows sum
        to 1).
    distance_mm : (N,) float64, mm
        Unsigned distance to the surface.
    """

    face_ids: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    distance_mm: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SurfaceIndex:
    """A triangle mesh prepared for nearest-point queries.

    Pickles as its vertices and faces (the tree is rebuilt on load, in milliseconds), so
    slabs can be computed in worker processes.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
        Vertex positions (C-contiguous).
    faces : (F, 3) int64
        Triangles (C-contiguous), ``F >= 1``.
    tree : igl.AABB
        Bounding-box tree over the faces.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    tree: Any = field(repr=False)

    @classmethod
    def build(cls, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> SurfaceIndex:
        """Index the faces of a mesh.

        Parameters
        ----------
        vertices : (V, 3) float64, mm
            Vertex positions.
        faces : (F, 3) int64
            Triangles.
        """
        vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertices must be (V, 3), got shape {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise ValueError(f"faces must be (F, 3) with F >= 1, got shape {faces.shape}")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise ValueError(f"faces must index 0..{len(vertices) - 1}")
        vertices, faces = vertices.view(), faces.view()  # read-only views: the caller's
        vertices.setflags(write=False)  # arrays stay writable
        faces.setflags(write=False)
        tree = igl.AABB()
        tree.init(vertices, faces)
        return cls(vertices, faces, tree)

    @cached_property
    def regions(self) -> VoronoiRegions:
        """Voronoi-region bounds of the faces, edges and vertices (computed once)."""
        return voronoi_regions(self.vertices, self.faces)

    def __reduce__(self) -> tuple[Any, tuple[NDArray[np.float64], NDArray[np.int64]]]:
        return (SurfaceIndex.build, (self.vertices, self.faces))


def nearest_on_surface(surface: SurfaceIndex, points_mm: NDArray[np.float64]) -> Nearest:
    """Return the exact nearest surface point of each query point.

    Parameters
    ----------
    surface : SurfaceIndex
        The indexed mesh.
    points_mm : (N, 3) float64, mm
        Query points ``(x, y, z)``.

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
    points = _points(points_mm)
    face_ids, _ = nearest_faces(surface, points)
    return on_faces(surface, points, face_ids)


def nearest_faces(
    surface: SurfaceIndex, points_mm: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Return the face of the exact nearest surface point and the distance to it.

    The cheaper half of :func:`nearest_on_surface` (no barycentric coordinates), for
    queries that need the distance and the face only.

    Parameters
    ----------
    surface : SurfaceIndex
        The indexed mesh.
    points_mm : (N, 3) float64, mm
        Query points ``(x, y, z)``.

    Returns
    -------
    face_ids : (N,) int64
        Face holding the nearest point (one of them where several tie).
    distance_mm : (N,) float64, mm
        Unsigned distance to the surface.
    """
    points = _points(points_mm)
    face_ids = np.zeros(len(points), dtype=np.int64)
    distance = np.zeros(len(points), dtype=np.float64)
    for start in range(0, len(points), POINTS_PER_CHUNK):
        part = slice(start, start + POINTS_PER_CHUNK)
        chunk = np.ascontiguousarray(points[part])
        squared, ids, _ = surface.tree.squared_distance(surface.vertices, surface.faces, chunk)
        face_ids[part] = np.asarray(ids, dtype=np.int64)
        distance[part] = np.sqrt(np.maximum(np.asarray(squared, dtype=np.float64), 0.0))
    return face_ids, distance


def on_faces(
    surface: SurfaceIndex, points_mm: NDArray[np.float64], face_ids: NDArray[np.int64]
) -> Nearest:
    """Return the closest point of each query point within its given face.

    With ``face_ids`` from :func:`nearest_faces` this completes an exact nearest-point
    query (Ericson's Voronoi-region test [2]_).

    Parameters
    ----------
    surface : SurfaceIndex
        The indexed mesh.
    points_mm : (N, 3) float64, mm
        Query points ``(x, y, z)``.
    face_ids : (N,) int64
        One face per point.

    Returns
    -------
    Nearest
    """
    points = _points(points_mm)
    face_ids = np.asarray(face_ids, dtype=np.int64)
    barycentric = np.zeros((len(points), 3), dtype=np.float64)
    distance = np.zeros(len(points), dtype=np.float64)
    for start in range(0, len(points), POINTS_PER_CHUNK):
        part = slice(start, start + POINTS_PER_CHUNK)
        triangles = surface.vertices[surface.faces[face_ids[part]]]
        bary = closest_barycentric(points[part], triangles)
        closest = np.einsum("nc,nck->nk", bary, triangles)
        barycentric[part] = bary
        distance[part] = np.linalg.norm(points[part] - closest, axis=1)
    return Nearest(face_ids, barycentric, distance)


def winding_numbers(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], points_mm: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return the generalised winding number of points with respect to a mesh.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
        Vertex positions.
    faces : (F, 3) int64
        Triangles, counter-clockwise seen from outside.
    points_mm : (N, 3) float64, mm
        Query points ``(x, y, z)``.

    Returns
    -------
    (N,) float64
        1 inside a closed outward-oriented mesh, 0 outside (fractional near open parts).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> winding_numbers(v, f, np.array([[0.1, 0.1, 0.1], [1.0, 1.0, 1.0]])).round(6).tolist()
    [1.0, 0.0]
    """
    points = _points(points_mm)
    if len(faces) == 0 or len(points) == 0:
        return np.zeros(len(points))
    winding = igl.winding_number(
        np.ascontiguousarray(vertices, dtype=np.float64),
        np.ascontiguousarray(faces, dtype=np.int64),
        np.ascontiguousarray(points),
    )
    return np.asarray(winding, dtype=np.float64).reshape(len(points))


def _points(points_mm: NDArray[np.float64]) -> NDArray[np.float64]:
    points = np.asarray(points_mm, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points_mm must be (N, 3), got shape {points.shape}")
    return points


def distance_to_surface(
    surface: SurfaceIndex, points_mm: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return the exact unsigned distance ``(N,) float64`` mm of points ``(N, 3)`` mm."""
    return nearest_faces(surface, points_mm)[1]


def _region_weights(
    d1: NDArray[np.float64],
    d2: NDArray[np.float64],
    d3: NDArray[np.float64],
    d4: NDArray[np.float64],
    d5: NDArray[np.float64],
    d6: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ericson's Voronoi-region test: weights ``v`` of ``b`` and ``w`` of ``c``."""
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        total = va + vb + vc
        v, w = vb / total, vc / total
        v_ab = d1 / (d1 - d3)
        w_ac = d2 / (d2 - d6)
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    zero, one = np.zeros_like(d1), np.ones_like(d1)
    # Regions from lowest to highest priority; later assignments win (Ericson's order).
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), 1.0 - w_bc, w_bc),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), zero, w_ac),
        ((d6 >= 0) & (d5 <= d6), zero, one),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), v_ab, zero),
        ((d3 >= 0) & (d4 <= d3), one, zero),
        ((d1 <= 0) & (d2 <= 0), zero, zero),
    ]
    for mask, region_v, region_w in regions:
        v = np.where(mask, region_v, v)
        w = np.where(mask, region_w, w)
    bad = ~(np.isfinite(v) & np.isfinite(w))  # degenerate triangle with no region
    v = np.where(bad, 0.0, v)
    w = np.where(bad, 0.0, w)
    return v, w


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
    ab, ac, ap = b - a, c - a, points - a
    d1, d2 = (ab * ap).sum(axis=1), (ac * ap).sum(axis=1)
    ab_ab, ab_ac, ac_ac = (ab * ab).sum(axis=1), (ab * ac).sum(axis=1), (ac * ac).sum(axis=1)
    v, w = _region_weights(d1, d2, d1 - ab_ab, d2 - ab_ac, d1 - ab_ac, d2 - ac_ac)
    result: NDArray[np.float64] = np.stack([1.0 - v - w, v, w], axis=1)
    return result
