"""Which sections to show first: on each axis the plane with the most vivid colour.

``shellvox inspect``'s section previews and ``shellvox view``'s opening slice both ask
:class:`SectionCounts`, fed the z pages of ``layers.tif`` and ``colour.tif`` one at a
time: a colour-layer voxel is *vivid* when its sRGB channels span more than
:data:`VIVID_SPAN`; on each axis the chosen plane is the one with the most vivid voxels
among the planes crossing the middle :data:`MIDDLE` of the part (so the plane crosses
the surface instead of running inside the coloured skin), ties going to the most central.
Mid planes are no good default: on the default model they fall on the grey gaps between
the colour patches.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

#: A colour-layer voxel is vivid when its sRGB channels span more than this.
VIVID_SPAN = 24
#: Sections are chosen among the planes in this middle fraction of the part.
MIDDLE = 0.6


def vivid_voxels(
    layers: NDArray[np.uint8], rgb: NDArray[np.uint8], colour_layers: Iterable[int]
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Return the colour-layer voxels of a page, and those of them that are vivid.

    Parameters
    ----------
    layers : (Y, X) uint8
        Layer indices of one page.
    rgb : (Y, X, 3) uint8
        Its colour (sRGB codes; more channels are ignored).
    colour_layers : iterable of int
        The layers that take the surface colour.

    Returns
    -------
    coloured, vivid : (Y, X) bool
    """
    is_colour = np.zeros(256, dtype=bool)
    is_colour[list(colour_layers)] = True
    coloured = is_colour[layers]
    where = np.flatnonzero(coloured)  # the colour layers are a thin skin: few voxels
    r, g, b = rgb.reshape(-1, rgb.shape[-1])[where, :3].T.astype(np.int16)
    span = np.maximum(np.maximum(r, g), b) - np.minimum(np.minimum(r, g), b)
    vivid = np.zeros(coloured.shape, dtype=bool)
    vivid.reshape(-1)[where] = span > VIVID_SPAN
    return coloured, vivid


def choose_section(vivid: NDArray[np.int64], inside: NDArray[np.bool_]) -> int:
    """Return the plane with the most vivid voxels mid-part (ties: the most central).

    Parameters
    ----------
    vivid : (N,) int64
        Vivid colour-layer voxels of each plane along one axis.
    inside : (N,) bool
        Whether each plane holds any voxel of the part (layer above 0).

    Examples
    --------
    >>> choose_section(np.array([0, 9, 1, 2, 2, 1, 0]), np.array([0, 1, 1, 1, 1, 1, 0], bool))
    3
    """
    where = np.nonzero(inside)[0]
    if not len(where):
        return len(vivid) // 2
    low, high = int(where[0]), int(where[-1])
    margin = (1 - MIDDLE) / 2 * (high - low)
    first, last = int(np.ceil(low + margin)), int(np.floor(high - margin))
    if last < first:
        first = last = (low + high) // 2
    candidates = np.arange(first, last + 1)
    centre = (low + high) / 2
    best = vivid[candidates].max()
    ties = candidates[vivid[candidates] == best]
    return int(ties[np.argmin(np.abs(ties - centre))])


class SectionCounts:
    """Vivid voxels and the part's extent per plane on each axis, page by page.

    Parameters
    ----------
    shape_zyx : (3,) int
        The grid.
    colour_layers : iterable of int
        The layers that take the surface colour.
    """

    def __init__(self, shape_zyx: tuple[int, int, int], colour_layers: Iterable[int]) -> None:
        self.colour_layers = tuple(colour_layers)
        self.vivid = {a: np.zeros(n, np.int64) for a, n in zip("zyx", shape_zyx, strict=True)}
        self.inside = {a: np.zeros(n, bool) for a, n in zip("zyx", shape_zyx, strict=True)}
        self.colour_voxels = np.zeros(shape_zyx[0], np.int64)

    def add_page(
        self, z: int, layers: NDArray[np.uint8], rgb: NDArray[np.uint8], y0: int = 0
    ) -> NDArray[np.bool_]:
        """Count page `z`, or its rows from `y0` on (``(n, X)`` layers, ``(n, X, 3+)`` colour).

        Every row of every page is to be counted once. Returns the colour voxels.
        """
        coloured, vivid = vivid_voxels(layers, rgb, self.colour_layers)
        y1 = y0 + len(layers)
        self.colour_voxels[z] += np.count_nonzero(coloured)
        self.vivid["z"][z] += np.count_nonzero(vivid)
        self.vivid["y"][y0:y1] += np.count_nonzero(vivid, axis=1)
        self.vivid["x"] += np.count_nonzero(vivid, axis=0)
        inside = layers > 0
        self.inside["z"][z] |= inside.any()
        self.inside["y"][y0:y1] |= inside.any(axis=1)
        self.inside["x"] |= inside.any(axis=0)
        return coloured

    def chosen(self) -> dict[str, int]:
        """Return the chosen plane on each axis (``{"z": ..., "y": ..., "x": ...}``)."""
        return {axis: choose_section(self.vivid[axis], self.inside[axis]) for axis in "zyx"}
