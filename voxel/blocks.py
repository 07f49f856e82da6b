"""Bounds on the surface distance of whole blocks of voxels, from one query per block.

Distance to a set is 1-Lipschitz: a voxel centre ``p`` of a block whose centre is ``c``
and whose half-diagonal (largest distance from ``c`` to a voxel centre of the block) is
``h`` has ``dist(c) - h <= dist(p) <= dist(c) + h``. The exact distance of one point per
block (libigl's AABB tree, :func:`voxel.nearest.distance_to_surface`) thus bounds all its
voxels, which is how narrow-band methods skip far space [1]_; here it decides which voxels
need their own nearest-point query and which lie wholly in one band or in the core.

Two levels keep the block queries few: coarse blocks of ``COARSE ** 3`` fine blocks are
queried first, and fine blocks only inside coarse blocks that can reach within ``reach``
of the surface. Blocks are aligned to the slab's first row and may overhang the grid;
only their real voxels are ever used, so the bounds hold for any slab split.

References
----------
.. [1] K. Museth, "VDB: High-resolution sparse volumes with dynamic topology", ACM TOG
   32(3), 2013 (hierarchical narrow bands).
"""

from __future__ import annotations

import math
from typing import NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

from voxel.grid import GridSpec
from voxel.nearest import SurfaceIndex, distance_to_surface

ScalarT = TypeVar("ScalarT", bound=np.generic)

#: Fine blocks per coarse block along each axis.
COARSE = 4
#: Edge length of a fine block as a fraction of the reach ...
FINE_FRACTION = 0.15
#: ... but at least this many of the grid's largest voxel edge.
MIN_EDGE_VOXELS = 2
#: Slack added to the bounds (mm) against rounding of the distances.
SLACK_MM = 1e-9


class BlockBounds(NamedTuple):
    """Distance bounds per fine block of a slab.

    Attributes
    ----------
    size : (3,) int
        Fine block ``(bz, by, bx)`` in voxels; block ``(i, j, k)`` holds slab voxels
        ``(i * bz .. , j * by .., k * bx ..)``.
    lower_mm : (Bz, By, Bx) float64, mm
        Lower bound of the distance of every voxel centre of the block; ``inf`` where the
        block is known to lie farther than the reach.
    upper_mm : (Bz, By, Bx) float64, mm
        Upper bound (``inf`` where ``lower_mm`` is).
    n_queries : int
        Distance queries made (both levels).
    """

    size: tuple[int, int, int]
    lower_mm: NDArray[np.float64]
    upper_mm: NDArray[np.float64]
    n_queries: int

    def expand(self, values: NDArray[ScalarT], shape: tuple[int, int, int]) -> NDArray[ScalarT]:
        """Return per-block ``values (Bz, By, Bx)`` repeated onto the slab's voxels ``shape``."""
        out = values
        for axis, step in enumerate(self.size):
            out = np.repeat(out, step, axis=axis)
        return out[: shape[0], : shape[1], : shape[2]]


def fine_block_size(grid: GridSpec, reach_mm: float) -> tuple[int, int, int]:
    """Return the fine block ``(bz, by, bx)``: edges of about ``FINE_FRACTION * reach_mm``.

    Never smaller than ``MIN_EDGE_VOXELS`` of the largest voxel edge, so that a block
    query always stands for several voxels.
    """
    vx, vy, vz = grid.voxel_mm
    edge = max(FINE_FRACTION * reach_mm, MIN_EDGE_VOXELS * max(vx, vy, vz))
    return tuple(max(1, round(edge / v)) for v in (vz, vy, vx))  # type: ignore[return-value]


def block_bounds(
    surface: SurfaceIndex, grid: GridSpec, z_start: int, z_stop: int, reach_mm: float
) -> BlockBounds:
    """Return distance bounds of the fine blocks of rows ``z_start..z_stop``.

    Parameters
    ----------
    surface : SurfaceIndex
        The surface distances are measured to.
    grid : GridSpec
        The voxel grid.
    z_start, z_stop : int
        Rows of the slab.
    reach_mm : float, mm
        Distance of interest (> 0): blocks whose voxels all lie farther get ``inf``.

    Returns
    -------
    BlockBounds
    """
    if not reach_mm > 0:
        raise ValueError(f"reach_mm must be > 0, got {reach_mm}")
    fine = np.array(fine_block_size(grid, reach_mm))
    voxel_zyx = np.asarray(grid.voxel_mm[::-1], dtype=np.float64)
    shape = np.array([z_stop - z_start, grid.shape_zyx[1], grid.shape_zyx[2]])
    n_fine = -(-shape // fine)
    n_coarse = -(-n_fine // COARSE)

    coarse_index = np.stack(np.unravel_index(np.arange(int(np.prod(n_coarse))), n_coarse), 1)
    coarse_size = fine * COARSE
    coarse_d = _centre_distance(surface, grid, z_start, coarse_index, coarse_size)
    coarse_half = _half_diagonal(coarse_size, voxel_zyx)
    near = coarse_index[coarse_d < reach_mm + coarse_half + SLACK_MM]

    offsets = np.stack(np.unravel_index(np.arange(COARSE**3), (COARSE,) * 3), 1)
    fine_index = (near[:, None, :] * COARSE + offsets[None]).reshape(-1, 3)
    fine_index = fine_index[np.all(fine_index < n_fine, axis=1)]
    fine_d = _centre_distance(surface, grid, z_start, fine_index, fine)
    fine_half = _half_diagonal(fine, voxel_zyx)

    lower = np.full(tuple(n_fine), np.inf)
    upper = np.full(tuple(n_fine), np.inf)
    where = tuple(fine_index.T)
    lower[where] = np.maximum(fine_d - fine_half - SLACK_MM, 0.0)
    upper[where] = fine_d + fine_half + SLACK_MM
    size = (int(fine[0]), int(fine[1]), int(fine[2]))
    return BlockBounds(size, lower, upper, len(coarse_index) + len(fine_index))


def _centre_distance(
    surface: SurfaceIndex,
    grid: GridSpec,
    z_start: int,
    index: NDArray[np.int64],
    size: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Distance of the centres of blocks ``index (N, 3)`` of ``size (3,)`` voxels."""
    centre = index * size + (size - 1) / 2.0
    centre[:, 0] += z_start
    return distance_to_surface(surface, grid.index_to_world(centre))


def _half_diagonal(size: NDArray[np.int64], voxel_zyx: NDArray[np.float64]) -> float:
    """Largest distance (mm) from a block's centre to one of its voxel centres."""
    return math.hypot(*((size - 1) * voxel_zyx / 2.0))
