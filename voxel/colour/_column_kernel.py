"""The compiled walk of the colour report's rays through one slab of material voxels.

Every sample has a disc of rays (:class:`Discs`): one ray at each point ``(p s_u,
q s_v)`` (integers ``p``, ``q``) of a lattice in its tangent plane that lies within the
disc's radius, lowered onto the quadric height field fitted to the surface under the
disc; it goes inward along the quadric's normal there. The spacings follow the voxels
(:func:`lattice_spacing`): every voxel column under a flat, axis-aligned disc is read by
one ray, so the disc's shares are counted, not sampled. The rays are made as they are
walked, so none is stored.

Each ray steps inward one smallest voxel size ``h`` at a time, the steps at depths
``(j + 1/4) h``, and each step counts the material of the voxel with the nearest centre
(as ``np.rint`` of the grid coordinates gives it) in its sample's depth bin. The quarter
keeps the steps off the boundaries between voxels on faces that lie on a plane of voxel
centres or of voxel faces (the axis-aligned faces of a model whose grid starts a whole
number of voxels from them): steps at half-steps would fall on those boundaries, where
rounding picks either voxel, reading some layers twice and others not at all. (A face a
quarter voxel off such a plane is these steps' worst case; it needs a coordinate that
no grid placement or model scale makes common.)

A slab of rows ``z0 .. z1 - 1`` visits only the steps that can fall in those rows
(bounded from the ray's z), and a step counts only where its voxel's row is in the slab:
every step is counted once, however the rows are cut into slabs.

Caller: :class:`shellvox.voxel.colour._model_report.ModelReport`. Nothing here checks its input.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

#: Most rays of one disc: larger discs read every ``m``-th lattice point (``m`` odd, so
#: the lattice still steps through every residue of the halftone's even-sized tile).
MAX_RAYS = 1024


def lattice_spacing(
    tangents: NDArray[np.float64], radius_mm: NDArray[np.float64], voxel_mm: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return each disc's lattice spacing along ``u`` and ``v`` ``(N, 2)`` mm.

    Along a tangent, the shortest step that crosses one voxel along some axis
    (``min_k voxel_k / |t_k|``), times the least odd ``m`` that keeps the disc within
    :data:`MAX_RAYS`.

    Parameters
    ----------
    tangents : (N, 2, 3) float64
        Unit tangents ``u``, ``v`` of each disc.
    radius_mm : (N,) float64, mm
    voxel_mm : (3,) float64, mm
        Voxel size ``(x, y, z)``.
    """
    with np.errstate(divide="ignore"):
        step = (np.asarray(voxel_mm, np.float64) / np.abs(tangents)).min(axis=2)  # (N, 2)
    rays = np.pi * radius_mm**2 / (step[:, 0] * step[:, 1])
    m = np.ceil(np.sqrt(rays / MAX_RAYS))
    m = np.maximum(m + (m % 2 == 0), 1.0)
    spacing: NDArray[np.float64] = step * m[:, None]
    return spacing


class Discs(NamedTuple):
    """The report's discs of rays and how the rays step.

    Attributes
    ----------
    frame : (N, 4, 3) float64
        Per sample: its point ``(x, y, z)`` in mm, then the unit tangents ``u``, ``v`` and
        the unit outward normal ``n`` (``u x v = n``).
    radius : (N,) float64, mm
        Radius of each disc.
    spacing : (N, 2) float64, mm
        The lattice's spacing along ``u`` and ``v`` (:func:`lattice_spacing`).
    quadric : (N, 5) float64, mm
        The surface's height below the tangent plane at unit-disc coordinates ``(a, b)``:
        ``c0 a^2 + c1 a b + c2 b^2 + c3 a + c4 b`` (all 0 for a flat disc).
    grid : (6,) float64
        ``origin_mm`` then ``voxel_mm``, each ``(x, y, z)``.
    walk : (3,) float64
        Step length (mm), number of steps, depth-bin thickness (mm).
    """

    frame: NDArray[np.float64]
    radius: NDArray[np.float64]
    spacing: NDArray[np.float64]
    quadric: NDArray[np.float64]
    grid: NDArray[np.float64]
    walk: NDArray[np.float64]


@kernel
def ray(
    discs: Discs, i: int, a: float, b: float
) -> tuple[float, float, float, float, float, float]:
    """Return the start ``(x, y, z)`` and inward direction of disc `i`'s ray at ``(a, b)``.

    ``(a, b)`` are coordinates on the unit disc.
    """
    c = discs.quadric[i]
    r = discs.radius[i]
    h = c[0] * a * a + c[1] * a * b + c[2] * b * b + c[3] * a + c[4] * b
    ha = (2.0 * c[0] * a + c[1] * b + c[3]) / r
    hb = (c[1] * a + 2.0 * c[2] * b + c[4]) / r
    f = discs.frame[i]
    start = f[0] + r * (a * f[1] + b * f[2]) - h * f[3]
    outward = f[3] + ha * f[1] + hb * f[2]
    norm = math.sqrt(outward[0] ** 2 + outward[1] ** 2 + outward[2] ** 2)
    return (
        start[0],
        start[1],
        start[2],
        -outward[0] / norm,
        -outward[1] / norm,
        -outward[2] / norm,
    )


@kernel
def walk(
    discs: Discs,
    i: int,
    a: float,
    b: float,
    z0: int,
    materials: NDArray[np.uint8],
    counts: NDArray[np.int32],
) -> None:
    """Count the steps in rows ``z0 ..`` of disc `i`'s ray at ``(a, b)``."""
    n_z, n_y, n_x = materials.shape
    n_bins, n_materials = counts.shape[1], counts.shape[2]
    step, n_steps, bin_mm = discs.walk[0], int(discs.walk[1]), discs.walk[2]
    ox, oy, oz = discs.grid[0], discs.grid[1], discs.grid[2]
    vx, vy, vz = discs.grid[3], discs.grid[4], discs.grid[5]
    low = oz + (z0 - 0.5) * vz
    high = oz + (z0 + n_z - 0.5) * vz
    sx, sy, sz, dx, dy, dz = ray(discs, i, a, b)
    if abs(dz) < 1e-12:
        if sz < low or sz >= high:
            return
        first, last = 0, n_steps - 1
    else:
        d0, d1 = (low - sz) / dz, (high - sz) / dz
        first = max(int(np.floor(min(d0, d1) / step - 0.25)) - 1, 0)
        last = min(int(np.ceil(max(d0, d1) / step - 0.25)) + 1, n_steps - 1)
    for j in range(first, last + 1):
        depth = (j + 0.25) * step
        iz = int(np.rint((sz + dz * depth - oz) / vz)) - z0
        if iz < 0 or iz >= n_z:
            continue
        iy = int(np.rint((sy + dy * depth - oy) / vy))
        ix = int(np.rint((sx + dx * depth - ox) / vx))
        if iy < 0 or iy >= n_y or ix < 0 or ix >= n_x:
            continue
        bin_ = min(int(depth / bin_mm), n_bins - 1)
        m = materials[iz, iy, ix]
        if m < n_materials:
            counts[i, bin_, m] += 1


@kernel
def count_slab(
    discs: Discs, z0: int, materials: NDArray[np.uint8], counts: NDArray[np.int32]
) -> None:
    """Add each ray step's material in rows ``z0 ..`` to ``counts[sample, bin, material]``."""
    z_low = discs.grid[2] + (z0 - 0.5) * discs.grid[5]
    z_high = discs.grid[2] + (z0 + materials.shape[0] - 0.5) * discs.grid[5]
    reach = discs.walk[0] * discs.walk[1]
    for i in range(discs.radius.shape[0]):
        r = discs.radius[i]
        # |height| <= the sum of the quadric's |coefficients| on the unit disc
        extent = r + np.abs(discs.quadric[i]).sum() + reach
        z = discs.frame[i, 0, 2]
        if z + extent < z_low or z - extent > z_high:
            continue  # no ray of this disc reaches the slab's rows
        su, sv = discs.spacing[i, 0], discs.spacing[i, 1]
        pu, pv = int(r / su), int(r / sv)
        for p in range(-pu, pu + 1):
            for q in range(-pv, pv + 1):
                a, b = p * su / r, q * sv / r
                if a * a + b * b <= 1.0:
                    walk(discs, i, a, b, z0, materials, counts)
