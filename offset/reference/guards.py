"""Checks a robust shell (:mod:`~.reference.robust`) must pass before it is accepted.

manifold3d's Booleans always return a closed manifold, but near-coplanar overlaps of
pieces occasionally give a geometrically wrong one: crossing triangles, or a thin crack
or a fold of the shell cut deeper than any piece reaches. Both are found here;
:mod:`shellvox.offset.reference.robust` then recomputes the core around the deep triangles, or tries
another order of the Booleans.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.spatial
import trimesh

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.voxel.geometry._nearest import SurfaceIndex, nearest_faces

#: A shell point deeper than ``(1 + DEEP_TOLERANCE) * D`` is a defect: the pieces reach
#: at most ``5e-5 D`` deeper than asked.
DEEP_TOLERANCE = 1e-3


class Surface:
    """The original surface, for depth checks of shell points.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    """

    def __init__(self, vertices: FloatArray, faces: IntArray) -> None:
        #: The faces indexed for exact nearest-point queries (libigl's tree).
        self.index = SurfaceIndex.build(vertices, faces)
        #: (V, 3) float64 and (F, 3) int64 (read-only views of the index's arrays).
        self.vertices, self.faces = self.index.vertices, self.index.faces
        crossing = intersecting_pairs(vertices, faces)
        #: (C, 3) float64 mm: corners of input faces that cross another input face.
        self.crossing_points = np.asarray(vertices[faces[np.unique(crossing)]].reshape(-1, 3))
        #: int: number of crossing input face pairs.
        self.n_crossing = int(crossing.shape[0])
        tri = self.vertices[self.faces]
        centre = tri.mean(axis=1)
        #: (F, 3) float64 mm and (F,) float64 mm: face centroids and the largest distance
        #: from a centroid to its corners, for finding the faces near a point.
        self.centres = centre
        self.reach = np.linalg.norm(tri - centre[:, None, :], axis=2).max(axis=1)
        self._centre_tree: scipy.spatial.cKDTree | None = None

    def within_depth(
        self, points: FloatArray, depth: FloatArray, slack: float
    ) -> npt.NDArray[np.bool_]:
        """Return which points lie within ``(1 + slack) * D_f`` of some face ``f``.

        Exact point-triangle distances (:func:`trimesh.triangles.closest_point`) to every
        face whose bounding sphere comes that close.

        Parameters
        ----------
        points : (n, 3) float64, mm
        depth : (F,) float64, mm
        slack : float

        Returns
        -------
        (n,) bool
        """
        if len(points) == 0:
            return np.zeros(0, dtype=bool)
        if self._centre_tree is None:
            self._centre_tree = scipy.spatial.cKDTree(self.centres)
        radius = (1.0 + slack) * float(depth.max()) + float(self.reach.max())
        near = scipy.spatial.cKDTree(points).sparse_distance_matrix(
            self._centre_tree, radius, output_type="ndarray"
        )
        which = np.asarray(near["i"], dtype=np.int64)
        face = np.asarray(near["j"], dtype=np.int64)
        foot = trimesh.triangles.closest_point(  # type: ignore[no-untyped-call]
            self.vertices[self.faces[face]], points[which]
        )
        dist = np.linalg.norm(foot - points[which], axis=1)
        hit = dist <= (1.0 + slack) * depth[face]
        out = np.zeros(len(points), dtype=bool)
        out[which[hit]] = True
        return out


def too_deep_count(
    surface: Surface, depth: FloatArray, vertices: FloatArray, faces: IntArray
) -> int:
    """Return how many shell triangles have their centroid deeper than allowed.

    See :func:`too_deep`.
    """
    return int(np.count_nonzero(too_deep(surface, depth, vertices, faces)))


def too_deep(
    surface: Surface, depth: FloatArray, vertices: FloatArray, faces: IntArray
) -> npt.NDArray[np.bool_]:
    """Return which shell triangles have their centroid deeper than allowed.

    A centroid is too deep when it lies farther than ``(1 + DEEP_TOLERANCE) D_f`` from
    every face ``f``: no piece reaches it (pieces are inscribed in those bands). First
    the nearest surface face and the faces around it (its vertices' incident faces) are
    checked, then, for centroids beyond those, every face within reach (where depths
    step, the deeper face's rounded edge reaches under several rings of shallower
    faces). Points within twice the largest depth of a self-intersecting part of the
    input are skipped (no well-defined solid there).

    Parameters
    ----------
    surface : Surface
    depth : (F,) float64, mm
        The layer's depth per original face.
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
        The shell.

    Returns
    -------
    (m,) bool
    """
    if faces.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    centroid = np.ascontiguousarray(vertices[faces].mean(axis=1), dtype=np.float64)
    # Exact nearest surface point per centroid (libigl's AABB tree: O(m log F) time and
    # O(m) memory; trimesh.proximity.closest_point builds per-candidate arrays).
    face, dist = nearest_faces(surface.index, centroid)
    vdepth = np.zeros(len(surface.vertices))
    np.maximum.at(vdepth, surface.faces.reshape(-1), np.repeat(depth, 3))
    allowed = vdepth[surface.faces[face]].max(axis=1)
    deep = dist > (1.0 + DEEP_TOLERANCE) * allowed
    if np.any(deep):
        idx = np.flatnonzero(deep)
        deep[idx[surface.within_depth(centroid[idx], depth, DEEP_TOLERANCE)]] = False
    if surface.n_crossing and np.any(deep):
        tree = scipy.spatial.cKDTree(surface.crossing_points)
        near, _ = tree.query(centroid[deep])
        deep[np.flatnonzero(deep)[near <= 2.0 * float(depth.max())]] = False
    return np.asarray(deep, dtype=bool)
