"""Surface colour for voxels: the colour of the exact nearest point on the original surface."""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.geometry import Nearest


class ColourAt(Protocol):
    """``colour_at(face_ids (N,) int, barycentric (N, 3) float) -> (N, 4) uint8 sRGBA``."""

    def __call__(
        self, face_ids: NDArray[np.int64], barycentric: NDArray[np.float64], /
    ) -> NDArray[np.uint8]:
        """Return the sRGB + alpha colour of surface points."""
        ...


def nearest_colour(nearest: Nearest, colour_at: ColourAt) -> NDArray[np.uint8]:
    """Return the colour ``(N, 4) uint8`` sRGBA of each query's nearest surface point.

    Colours are looked up, never averaged: each voxel takes exactly the colour of one
    surface point.
    """
    rgba = np.asarray(colour_at(nearest.face_ids, nearest.barycentric))
    if rgba.shape != (len(nearest.face_ids), 4) or rgba.dtype != np.uint8:
        raise ValueError(
            f"colour_at must return ({len(nearest.face_ids)}, 4) uint8, "
            f"got {rgba.shape} {rgba.dtype}"
        )
    return rgba
