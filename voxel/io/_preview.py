"""The display colours of a layered stack's previews and the in-plane depth of its bands.

The pictures themselves are drawn by :mod:`shellvox.report`; this module holds what the
writers and the report share: arrays in, arrays out.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

#: Display colour of layer 0 (outside), the bands (cycled) and the core (last).
OUTSIDE_RGB = (255, 255, 255)
BAND_RGB = ((120, 120, 120), (170, 150, 110), (110, 150, 170), (150, 110, 170))
CORE_RGB = (60, 60, 60)


def boundary_depths(
    layers: NDArray[np.uint8], pixel_mm: tuple[float, float], n_bands: int
) -> list[NDArray[np.float64]]:
    """Return, per band ``k``, the in-plane depth (mm) of its voxels next to band ``k + 1``.

    Depth is the section's 2-D Euclidean distance to the nearest outside voxel, which is
    at least the true 3-D depth (equal where the surface is perpendicular to the plane).
    """
    depth = ndimage.distance_transform_edt(layers > 0, sampling=(pixel_mm[1], pixel_mm[0]))
    result = []
    for band in range(1, n_bands + 1):
        deeper = ndimage.binary_dilation(layers > band)
        result.append(np.asarray(depth[(layers == band) & deeper], dtype=np.float64))
    return result


#: How much lighter the layers under the colour are drawn in a colour section.
FADE = 0.55
