"""Surface colour for voxels: the colour of the exact nearest point on the original surface."""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from voxel.nearest import Nearest


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


def _srgb_decode(value: NDArray[np.float32]) -> NDArray[np.float32]:
    """Return the sRGB decoding curve (IEC 61966-2-1) of values in ``[0, 1]``."""
    linear: NDArray[np.float32] = np.where(
        value <= 0.04045, value / np.float32(12.92), ((value + 0.055) / 1.055) ** 2.4
    ).astype(np.float32)
    return linear


#: Linear value of each 8-bit sRGB code: decoding is one gather per channel.
_LINEAR_OF_CODE = _srgb_decode(np.arange(256, dtype=np.float32) / np.float32(255.0))


def srgb_to_linear(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Return linear-light RGB in ``[0, 1]`` (float32) of 8-bit sRGB (IEC 61966-2-1).

    Examples
    --------
    >>> [round(float(v), 4) for v in srgb_to_linear(np.array([0, 128, 255], np.uint8))]
    [0.0, 0.2159, 1.0]
    """
    codes = np.asarray(rgb)
    if codes.dtype != np.uint8:
        raise ValueError(f"rgb must be uint8 sRGB codes, got {codes.dtype}")
    linear: NDArray[np.float32] = _LINEAR_OF_CODE[codes]
    return linear
