"""Where the previews cut their sections: on each axis a plane that holds every layer.

:class:`LayerCounts` counts, page by page of ``layers.tif``, the voxels of each layer in
every plane along z, y and x (per page, one comparison for each inside layer it holds;
the outside is the rest). :func:`choose_plane` then picks, on one axis, among the planes
that hold every layer present in the volume (or, if none does, the most layers), those
with at least :data:`CORE_SHARE` of the most core any of them holds; of these, the one
with the most vivid colour-layer voxels (:class:`shellvox.viewer.SectionCounts`), then
the most core, then the most central. A plane through a thin part (an ear, a handle, a
rim) shows the colour layers but no core; a plane through a grey gap between colour
patches shows the layers but little colour: both are passed over.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: A candidate plane holds at least this share of the most core of any candidate.
CORE_SHARE = 0.5


class LayerCounts:
    """Voxels of each layer in every plane along each axis, gathered page by page.

    Parameters
    ----------
    shape_zyx : (3,) int
        The grid.

    Attributes
    ----------
    counts : dict of str to (N, 256) int64
        Per axis (``"z"``, ``"y"``, ``"x"``), per plane, the voxels of each layer index.
    """

    def __init__(self, shape_zyx: tuple[int, int, int]) -> None:
        self.counts = {
            a: np.zeros((n, 256), np.int64) for a, n in zip("zyx", shape_zyx, strict=True)
        }

    def add_page(self, z: int, layers: NDArray[np.uint8]) -> None:
        """Count page ``z``, ``(Y, X) uint8`` layer indices (each page once)."""
        n_y, n_x = layers.shape
        in_page = np.bincount(layers.ravel(), minlength=256)
        self.counts["z"][z] += in_page
        outside_y, outside_x = np.full(n_y, n_x, np.int64), np.full(n_x, n_y, np.int64)
        for layer in np.flatnonzero(in_page[1:]) + 1:  # the few layers of the build
            found = layers == layer
            along_y, along_x = np.count_nonzero(found, axis=1), np.count_nonzero(found, axis=0)
            self.counts["y"][:, layer] += along_y
            self.counts["x"][:, layer] += along_x
            outside_y -= along_y
            outside_x -= along_x
        self.counts["y"][:, 0] += outside_y  # layer 0 is the rest
        self.counts["x"][:, 0] += outside_x

    def chosen(self, core: int, vivid: dict[str, NDArray[np.int64]]) -> dict[str, int]:
        """Return the chosen plane on each axis (see :func:`choose_plane`)."""
        return {a: choose_plane(self.counts[a], core, vivid[a]) for a in "zyx"}


def choose_plane(counts: NDArray[np.int64], core: int, vivid: NDArray[np.int64]) -> int:
    """Return the plane that shows every layer, plenty of core and the most colour.

    Parameters
    ----------
    counts : (N, L) int64
        Voxels of each layer index in each plane along one axis (index 0: outside).
    core : int
        The core's layer index.
    vivid : (N,) int64
        Vivid colour-layer voxels in each plane.

    Returns
    -------
    int
        Among the planes holding every inside layer the volume holds (failing that: the
        most of them), those with at least :data:`CORE_SHARE` of their most core; of
        these the most vivid, then the most core, then the nearest the part's middle.

    Examples
    --------
    A thin plate (two layers, no core) beside a thick block (three layers):

    >>> counts = np.zeros((6, 4), np.int64)
    >>> counts[0:3, 1:4] = [9, 4, 2]  # the block: colour, backing, core
    >>> counts[3:6, 1:3] = [9, 9]  # the plate
    >>> int(choose_plane(counts, 3, np.array([0, 0, 1, 50, 50, 50])))
    2
    """
    counts = np.asarray(counts)
    inside = counts[:, 1:] > 0
    present = inside.any(axis=0)
    part = np.flatnonzero(inside.any(axis=1))
    if not len(part) or not present.any():
        return len(counts) // 2
    held = inside[:, present].sum(axis=1)
    candidate = held == held.max()
    core_voxels = counts[:, core] if core < counts.shape[1] else np.zeros(len(counts), np.int64)
    most_core = core_voxels[candidate].max()
    candidate &= core_voxels >= CORE_SHARE * most_core
    centre = (part[0] + part[-1]) / 2
    planes = np.flatnonzero(candidate)
    # lexicographic: most vivid, most core, least distance to the middle
    order = np.lexsort((np.abs(planes - centre), -core_voxels[planes], -vivid[planes]))
    return int(planes[order[0]])
