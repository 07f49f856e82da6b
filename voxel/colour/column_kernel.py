"""The compiled walk of the colour report's rays through one slab of material voxels.

Each ray steps inward along its sample's normal, one smallest voxel size at a time, and
each step counts the material of the voxel with the nearest centre (as ``np.rint`` of
the grid coordinates gives it) in its sample's depth bin. A slab of rows ``z0 .. z1 - 1``
visits only the steps that can fall in those rows (bounded from the ray's z), and a step
counts only where its voxel's row is in the slab: every step is counted once, however
the rows are cut into slabs.

Caller: :class:`voxel.colour.model_report.ModelReport`. Nothing here checks its input.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray


class Rays(NamedTuple):
    """The report's rays and how they step.

    Attributes
    ----------
    starts : (R, 3) float64, mm
        Start ``(x, y, z)`` of each ray, on the surface.
    inward : (R, 3) float64
        Unit direction into the part.
    sample : (R,) int64
        The sample each ray belongs to.
    grid : (6,) float64
        ``origin_mm`` then ``voxel_mm``, each ``(x, y, z)``.
    walk : (3,) float64
        Step length (mm), number of steps, depth-bin thickness (mm).
    """

    starts: NDArray[np.float64]
    inward: NDArray[np.float64]
    sample: NDArray[np.int64]
    grid: NDArray[np.float64]
    walk: NDArray[np.float64]


@numba.njit(cache=True, nogil=True)
def count_slab(
    rays: Rays, z0: int, materials: NDArray[np.uint8], counts: NDArray[np.int64]
) -> None:
    """Add each ray step's material in rows ``z0 ..`` to ``counts[sample, bin, material]``."""
    n_z, n_y, n_x = materials.shape
    n_bins, n_materials = counts.shape[1], counts.shape[2]
    step, n_steps, bin_mm = rays.walk[0], int(rays.walk[1]), rays.walk[2]
    ox, oy, oz = rays.grid[0], rays.grid[1], rays.grid[2]
    vx, vy, vz = rays.grid[3], rays.grid[4], rays.grid[5]
    low = oz + (z0 - 0.5) * vz
    high = oz + (z0 + n_z - 0.5) * vz
    for r in range(rays.starts.shape[0]):
        sx, sy, sz = rays.starts[r, 0], rays.starts[r, 1], rays.starts[r, 2]
        dx, dy, dz = rays.inward[r, 0], rays.inward[r, 1], rays.inward[r, 2]
        if abs(dz) < 1e-12:
            if sz < low or sz >= high:
                continue
            first, last = 0, n_steps - 1
        else:
            d0, d1 = (low - sz) / dz, (high - sz) / dz
            first = max(int(np.floor(min(d0, d1) / step - 0.5)) - 1, 0)
            last = min(int(np.ceil(max(d0, d1) / step - 0.5)) + 1, n_steps - 1)
        for j in range(first, last + 1):
            depth = (j + 0.5) * step
            iz = int(np.rint((sz + dz * depth - oz) / vz)) - z0
            if iz < 0 or iz >= n_z:
                continue
            iy = int(np.rint((sy + dy * depth - oy) / vy))
            ix = int(np.rint((sx + dx * depth - ox) / vx))
            if iy < 0 or iy >= n_y or ix < 0 or ix >= n_x:
                continue
            b = min(int(depth / bin_mm), n_bins - 1)
            m = materials[iz, iy, ix]
            if m < n_materials:
                counts[rays.sample[r], b, m] += 1
