"""Materials and texture sampling: wrap rules, bilinear filtering.

UV convention used everywhere in shellvox (OpenGL's, also OBJ's, PLY's and 3MF's):
``u`` grows to the right and ``v`` grows *up*, ``(0, 0)`` is the bottom-left corner of
the image and texel ``(row, col)`` has its centre at ``u = (col + 0.5) / W``,
``v = 1 - (row + 0.5) / H``. Loaders of formats with a top-left origin (glTF) convert
to this convention once, when they read the file.

Filtering happens in linear light (decode sRGB, weight, encode), as GPUs do for sRGB
textures, so a bilinear blend of two texels never darkens their mid-point (the sRGB
transfer is :mod:`shellvox.voxel.colour._srgb`'s).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour import decode_uint8

WrapMode = Literal["repeat", "clamp", "mirror"]
FilterMode = Literal["linear", "nearest"]


@dataclass(frozen=True, eq=False)
class Material:
    """A surface material: a base colour factor times an optional texture.

    Parameters
    ----------
    name : str
        Name from the file (for reports).
    factor : (4,) float64
        Linear RGB + alpha multiplier in ``[0, 1]`` (glTF ``baseColorFactor``; the
        decoded ``Kd`` of an OBJ material without texture; ``(1, 1, 1, 1)`` otherwise).
    image : (H, W, 4) uint8 or None
        sRGB + alpha texture, row 0 at the *top* of the picture, or None.
    wrap : (WrapMode, WrapMode)
        Wrap rule along ``u`` and ``v``.
    filter : FilterMode
        ``"linear"`` (bilinear) or ``"nearest"``.
    """

    name: str
    factor: NDArray[np.float64] = field(default_factory=lambda: np.ones(4))
    image: NDArray[np.uint8] | None = None
    wrap: tuple[WrapMode, WrapMode] = ("repeat", "repeat")
    filter: FilterMode = "linear"

    def sample(self, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the linear RGBA colour at texture coordinates.

        Parameters
        ----------
        uv : (N, 2) float64
            Texture coordinates in the shellvox convention (``v`` up).

        Returns
        -------
        (N, 4) float64
            Linear RGB + alpha in ``[0, 1]``: the filtered texel times ``factor``.
        """
        if self.image is None:
            return np.broadcast_to(self.factor, (len(uv), 4)).copy()
        height, width = self.image.shape[:2]
        # Continuous texel coordinates: texel (row, col) has its centre at (col, row).
        x = uv[:, 0] * width - 0.5
        y = (1.0 - uv[:, 1]) * height - 0.5
        if self.filter == "nearest":
            cols = _wrap(np.floor(x + 0.5).astype(np.int64), width, self.wrap[0])
            rows = _wrap(np.floor(y + 0.5).astype(np.int64), height, self.wrap[1])
            texel = decode_uint8(self.image[rows, cols])
        else:
            x0 = np.floor(x)
            y0 = np.floor(y)
            fx = (x - x0)[:, None]
            fy = (y - y0)[:, None]
            c0 = _wrap(x0.astype(np.int64), width, self.wrap[0])
            c1 = _wrap(x0.astype(np.int64) + 1, width, self.wrap[0])
            r0 = _wrap(y0.astype(np.int64), height, self.wrap[1])
            r1 = _wrap(y0.astype(np.int64) + 1, height, self.wrap[1])
            image = self.image
            texel = (
                decode_uint8(image[r0, c0]) * ((1 - fx) * (1 - fy))
                + decode_uint8(image[r0, c1]) * (fx * (1 - fy))
                + decode_uint8(image[r1, c0]) * ((1 - fx) * fy)
                + decode_uint8(image[r1, c1]) * (fx * fy)
            )
        result: NDArray[np.float64] = texel * self.factor
        return result


def _wrap(index: NDArray[np.int64], size: int, mode: WrapMode) -> NDArray[np.int64]:
    """Map integer texel indices into ``[0, size)`` with a wrap rule."""
    if mode == "repeat":
        return np.mod(index, size)
    if mode == "mirror":
        period = np.mod(index, 2 * size)
        return np.where(period < size, period, 2 * size - 1 - period)
    return np.clip(index, 0, size - 1)
