"""How well the distance realisation of the layers agrees with the shell meshes.

The voxel stack takes its layers from exact nearest-surface distances
(:mod:`shellvox.voxel.slab`); the offset shells (:mod:`offset`) are a second, independent
realisation of the same bands. On sampled voxels, the shell realisation's layer is one plus
the number of shells whose generalised winding number at the voxel centre exceeds 1/2
(:func:`shellvox.voxel.geometry._nearest.winding_numbers`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.geometry import SurfaceIndex, nearest_faces, winding_numbers

Surface = tuple[NDArray[np.float64], NDArray[np.int64]]


def shell_agreement(
    points_mm: NDArray[np.float64],
    layers: NDArray[np.uint8],
    surface: SurfaceIndex,
    depth_mm: NDArray[np.float64],
    shells: list[Surface],
    clear_mm: float,
) -> dict[str, Any]:
    """Compare distance-realised layers of inside voxels with the shells' layers.

    Parameters
    ----------
    points_mm : (N, 3) float64, mm
        Centres of sampled voxels inside the model.
    layers : (N,) uint8
        Their layers (1..K+1) in the voxel stack.
    surface : SurfaceIndex
        The original surface.
    depth_mm : (K, F) float64, mm
        Cumulative depth per band and original face.
    shells : list of (vertices (V, 3) float64 mm, faces (F, 3) int64)
        The ``K`` shell meshes, outside in (a collapsed shell has no faces).
    clear_mm : float, mm
        Samples farther than this from every layer boundary (``|d - D_k(f)|``) are
        "clear"; use the voxel diagonal.

    Returns
    -------
    dict
        ``samples``, ``agreement`` (fraction of all samples), ``samples_clear``,
        ``agreement_clear`` and ``per_layer`` (agreement of clear samples per layer).
    """
    points = np.asarray(points_mm, dtype=np.float64)
    layers = np.asarray(layers, dtype=np.int64)
    if len(points) == 0:
        return {"samples": 0}
    face_ids, distance_mm = nearest_faces(surface, points)  # no barycentrics needed
    boundary = depth_mm[:, face_ids]
    clear = np.all(np.abs(distance_mm[None, :] - boundary) > clear_mm, axis=0)
    by_shells = np.ones(len(points), dtype=np.int64)
    for vertices, faces in shells:
        if len(faces):
            by_shells += winding_numbers(vertices, faces, points) > 0.5
    same = by_shells == layers
    per_layer = {
        str(k): float(same[clear & (layers == k)].mean())
        for k in np.unique(layers)
        if np.any(clear & (layers == k))
    }
    return {
        "samples": len(points),
        "agreement": float(same.mean()),
        "samples_clear": int(clear.sum()),
        "agreement_clear": float(same[clear].mean()) if clear.any() else None,
        "per_layer": per_layer,
    }
