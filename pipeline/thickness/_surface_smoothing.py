"""Per-face values smoothed over a surface distance in millimetres.

Each face's value becomes the average of the values of the faces whose centroids lie
within ``radius_mm`` of its own, weighted by their area and by a tent
``1 - distance / radius_mm``, over faces facing the same side (``n_i . n_j > 0``: the two
sides of a thin wall do not mix). Since the weights are areas within a distance, the
result follows the surface, not its triangulation: a face with no other centroid within
the radius keeps its value, however large it is, and a finely triangulated region is
averaged over the same millimetres as a coarse one. The result is a convex combination
of the inputs, so it never leaves their range.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree


def smooth_over_distance(
    centroids: ArrayLike,
    normals: ArrayLike,
    areas: ArrayLike,
    values: ArrayLike,
    radius_mm: float,
) -> NDArray[np.float64]:
    """Smooth per-face `values` over `radius_mm` of surface (see the module).

    Parameters
    ----------
    centroids : (F, 3) float, mm
    normals : (F, 3) float
        Unit face normals.
    areas : (F,) float, mm^2
    values : (F,) float
    radius_mm : float, mm
        Smoothing radius (0: none).

    Returns
    -------
    (F,) float64

    Examples
    --------
    >>> c = [[0, 0, 0], [0.5, 0, 0], [5, 0, 0]]
    >>> n = [[0, 0, 1]] * 3
    >>> smooth_over_distance(c, n, [1, 1, 1], [1.0, 3.0, 9.0], 1.0).tolist()
    [1.6666666666666667, 2.3333333333333335, 9.0]
    """
    c = np.asarray(centroids, np.float64)
    n = np.asarray(normals, np.float64)
    a = np.asarray(areas, np.float64)
    v = np.asarray(values, np.float64)
    if radius_mm <= 0 or len(v) < 2:
        return v.copy()
    pairs = cKDTree(c).query_pairs(radius_mm, output_type="ndarray")  # (P, 2), i < j
    i, j = pairs[:, 0], pairs[:, 1]
    tent = 1.0 - np.linalg.norm(c[i] - c[j], axis=1) / radius_mm
    same_side = (n[i] * n[j]).sum(1) > 0
    w = np.where(same_side, tent, 0.0)
    total = a.copy()  # each face's own weight: its area
    weighted = a * v
    np.add.at(total, i, w * a[j])
    np.add.at(weighted, i, w * a[j] * v[j])
    np.add.at(total, j, w * a[i])
    np.add.at(weighted, j, w * a[i] * v[i])
    return np.asarray(weighted / total, np.float64)
