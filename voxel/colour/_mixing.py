"""The linear-light mixing model's solver (:mod:`~shellvox.voxel.colour._separation`, steps 1 to 3).

The proportions ``p`` of opaque materials with linear-RGB colours ``d_i`` whose mix
``sum_i p_i d_i`` is nearest the target, and among equally near mixes the one of least
expected squared CIELAB difference between one voxel and the target: every vertex of the
linear programme ``min c.p, D p = t, sum p = 1, p >= 0`` is enumerated at once, as the
barycentric coordinates of the target's projection on the affine hull of every subset of
at most four affinely independent materials.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._srgb import linear_to_lab

#: Projections closer than this (linear RGB) to the nearest count as equally near.
_DISTANCE_TIE = 1e-9
#: Barycentric coordinates down to this count as non-negative.
_INSIDE_TOL = 1e-9


def mix_proportions(
    targets: NDArray[np.float64], materials: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return the mixing-model proportions of linear-RGB targets (see the module).

    Parameters
    ----------
    targets : (N, 3) float64
        Linear RGB in ``[0, 1]``.
    materials : (P, 3) float64
        Linear RGB of the opaque materials.

    Returns
    -------
    (N, P) float64
        Non-negative proportions summing to 1: the nearest mix in linear RGB, and among
        equally near mixes the one of least ``sum_i p_i |Lab_i - Lab_target|^2``.
    """
    n_materials = len(materials)
    cost = _lab_cost(targets, materials)
    best = np.zeros((len(targets), n_materials))
    best_distance = np.full(len(targets), np.inf)
    best_cost = np.full(len(targets), np.inf)
    for size in range(1, min(n_materials, 4) + 1):
        for subset in itertools.combinations(range(n_materials), size):
            found = _project_on_subset(targets, materials[list(subset)])
            if found is None:
                continue
            weights, distance = found
            inside = np.all(weights >= -_INSIDE_TOL, axis=1)
            subset_cost = (weights * cost[:, list(subset)]).sum(axis=1)
            nearer = distance < best_distance - _DISTANCE_TIE
            as_near = np.abs(distance - best_distance) <= _DISTANCE_TIE
            take = inside & (nearer | (as_near & (subset_cost < best_cost)))
            if not np.any(take):
                continue
            clean = np.clip(weights[take], 0.0, None)
            clean /= clean.sum(axis=1, keepdims=True)
            best[take] = 0.0
            best[np.ix_(take, list(subset))] = clean
            best_distance[take] = np.minimum(distance[take], best_distance[take])
            best_cost[take] = subset_cost[take]
    return best


def _project_on_subset(
    targets: NDArray[np.float64], points: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Project the targets on the affine hull of ``points`` (k, 3).

    Returns barycentric coordinates ``(N, k)`` and distances ``(N,)``, or None when the
    points are affinely dependent.
    """
    origin = points[0]
    edges = (points[1:] - origin).T  # (3, k - 1)
    if edges.shape[1] > 0 and np.linalg.matrix_rank(edges, tol=1e-10) < edges.shape[1]:
        return None
    if edges.shape[1] == 0:
        local = np.zeros((len(targets), 0))
    else:
        local = (targets - origin) @ np.linalg.pinv(edges).T  # (N, k - 1)
    weights = np.concatenate([1.0 - local.sum(axis=1, keepdims=True), local], axis=1)
    distance = np.linalg.norm(weights @ points - targets, axis=1)
    return weights, distance


def _lab_cost(targets: NDArray[np.float64], materials: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return ``|Lab(material) - Lab(target)|^2`` (N, P), colours in linear sRGB."""
    difference = linear_to_lab(materials)[None, :, :] - linear_to_lab(targets)[:, None, :]
    cost: NDArray[np.float64] = (difference**2).sum(axis=2)
    return cost
