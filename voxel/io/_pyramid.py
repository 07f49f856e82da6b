"""The multiscale pyramid of a stack: factors per level, mode of labels, mean of colour.

Level ``k + 1`` halves the axes of level ``k`` whose voxels are finest (:func:`level_factors`):
an axis is halved when its doubled voxel is at most ``sqrt(2)`` times the coarsest voxel of
the level, and every axis when none is; so the J750's ``27 x 85 x 42 um`` voxels (z, y, x)
become ``54 x 85 x 85``, then ``108 x 85 x 85``, then double on all axes. Levels are added
while an axis is longer than ``min_extent`` voxels.

A block of level ``k`` (``fz x fy x fx`` voxels, fewer at the far edges) gives one voxel of
level ``k + 1``:

- labels (layers, materials): the most frequent value of the block, ties to the smallest
  (as :func:`scipy.stats.mode`);
- colour: the mean, in linear light, of the block's colour voxels weighted by how many
  colour-layer voxels of level 0 each stands for (:data:`shellvox.voxel.colour._srgb.DECODE_LUT_F32`
  decodes, the compiled kernel encodes as :func:`shellvox.voxel.colour._srgb.linear_to_srgb` does,
  tested equal); alpha is averaged as it is;
  0 where the block has no colour voxel.

Both kernels are compiled and release the GIL (the writer thread runs them beside the slabs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.colour._srgb import DECODE_LUT_F32

Factors = tuple[int, int, int]


def level_factors(
    voxel_zyx: Sequence[float], shape_zyx: Sequence[int], *, min_extent: int = 64
) -> list[Factors]:
    """Return the ``(fz, fy, fx)`` factor of each level after the first (see the module).

    Parameters
    ----------
    voxel_zyx : (3,) float, mm
        Voxel size of level 0, ``(z, y, x)``.
    shape_zyx : (3,) int
        Voxels of level 0.
    min_extent : int
        Levels are added while an axis of the last one has more voxels than this.

    Examples
    --------
    >>> level_factors((0.027, 0.0847, 0.0423), (261, 202, 592))
    [(2, 1, 2), (2, 1, 1), (2, 2, 2), (2, 2, 2), (2, 2, 2)]
    >>> level_factors((0.1, 0.1, 0.1), (10, 64, 64))
    []
    """
    size = [float(v) for v in voxel_zyx]
    shape = [int(n) for n in shape_zyx]
    factors: list[Factors] = []
    while max(shape) > min_extent and len(factors) < 16:
        movable = [a for a in range(3) if shape[a] > 1]
        coarse = max(size[a] for a in movable)
        halve = [a for a in movable if 2 * size[a] <= math.sqrt(2) * coarse] or movable
        step = tuple(2 if a in halve else 1 for a in range(3))
        factors.append((step[0], step[1], step[2]))
        size = [s * f for s, f in zip(size, step, strict=True)]
        shape = [-(-n // f) for n, f in zip(shape, step, strict=True)]
    return factors


def downsample_labels(labels: NDArray[np.uint8], factors: Factors) -> NDArray[np.uint8]:
    """Return the mode of every ``fz x fy x fx`` block of `labels`, ties to the smallest.

    Parameters
    ----------
    labels : (Z, Y, X) uint8
    factors : (3,) int
        Block size ``(fz, fy, fx)``; blocks at the far edges hold what is left.

    Returns
    -------
    (ceil(Z / fz), ceil(Y / fy), ceil(X / fx)) uint8

    Examples
    --------
    >>> downsample_labels(np.array([[[1, 2, 2, 0]]], np.uint8), (1, 1, 2)).tolist()
    [[[1, 0]]]
    """
    labels = np.ascontiguousarray(labels, dtype=np.uint8)
    out = np.empty(_shape(labels.shape, factors), dtype=np.uint8)
    _mode_kernel(labels, factors[0], factors[1], factors[2], out)
    return out


def downsample_colour(
    colour: NDArray[np.uint8], weight: NDArray[np.uint8] | NDArray[np.float32], factors: Factors
) -> tuple[NDArray[np.uint8], NDArray[np.float32]]:
    """Return the weighted mean in linear light of every block of `colour`, and its weight.

    Parameters
    ----------
    colour : (Z, Y, X, C) uint8
        sRGB codes (``C = 3``) and straight alpha (``C = 4``); any strides.
    weight : (Z, Y, X) uint8 or float32
        Colour-layer voxels of level 0 each voxel stands for (0: no colour there; level 0
        itself: 1 in the colour layers).
    factors : (3,) int
        Block size ``(fz, fy, fx)``.

    Returns
    -------
    colour : (Zk, Yk, Xk, C) uint8
        0 where a block has no weight.
    weight : (Zk, Yk, Xk) float32
        The blocks' total weight.
    """
    shape = _shape(weight.shape, factors)
    out = np.zeros((*shape, colour.shape[-1]), dtype=np.uint8)
    total = np.zeros(shape, dtype=np.float32)
    any_colour = np.any(np.asarray(weight).reshape(-1, weight.shape[-1]), axis=1)
    coloured_rows: NDArray[np.bool_] = np.reshape(any_colour, weight.shape[:2])  # (Z, Y)
    _mean_kernel(colour, weight, coloured_rows, DECODE_LUT_F32, *factors, out, total)
    return out, total


def _shape(shape: Sequence[int], factors: Factors) -> tuple[int, int, int]:
    z, y, x = (-(-int(n) // f) for n, f in zip(shape, factors, strict=True))
    return z, y, x


@kernel
def _block_mode(
    labels: NDArray[np.uint8],
    z0: int,
    z1: int,
    y0: int,
    y1: int,
    x0: int,
    x1: int,
    values: NDArray[np.uint8],
) -> Any:  # pragma: no cover - compiled
    """Return the most frequent value of one block of `labels`, ties to the smallest."""
    n = 0
    for z in range(z0, z1):
        for y in range(y0, y1):
            for x in range(x0, x1):
                values[n] = labels[z, y, x]
                n += 1
    best, best_count = values[0], 0
    for i in range(n):
        count = 0
        for j in range(n):
            if values[j] == values[i]:
                count += 1
        if count > best_count or (count == best_count and values[i] < best):
            best, best_count = values[i], count
    return best


@kernel
def _mode_kernel(
    labels: NDArray[np.uint8], fz: int, fy: int, fx: int, out: NDArray[np.uint8]
) -> None:  # pragma: no cover - compiled
    n_z, n_y, n_x = labels.shape
    n_ox = out.shape[2]
    differs = np.empty(n_x, dtype=np.uint8)  # nonzero where a row of the block row differs
    values = np.empty(fz * fy * fx, dtype=np.uint8)
    for oz in range(out.shape[0]):
        z0, z1 = oz * fz, min(n_z, oz * fz + fz)
        for oy in range(out.shape[1]):
            y0, y1 = oy * fy, min(n_y, oy * fy + fy)
            first = labels[z0, y0]  # the block row's first input row
            differs[:] = 0
            for z in range(z0, z1):  # whole rows at a time (vectorised)
                for y in range(y0, y1):
                    row = labels[z, y]
                    for x in range(n_x):
                        differs[x] |= row[x] ^ first[x]
            line = out[oz, oy]
            for ox in range(n_ox):  # most blocks hold one value: only the others counted
                x0, x1 = ox * fx, min(n_x, ox * fx + fx)
                value = first[x0]
                uniform = True
                for x in range(x0, x1):
                    if differs[x] != 0 or first[x] != value:
                        uniform = False
                if uniform:
                    line[ox] = value
                else:
                    line[ox] = _block_mode(labels, z0, z1, y0, y1, x0, x1, values)


@kernel
def _mean_kernel(
    colour: NDArray[np.uint8],
    weight: NDArray[np.uint8] | NDArray[np.float32],
    coloured_rows: NDArray[np.bool_],
    lut: NDArray[np.float32],
    fz: int,
    fy: int,
    fx: int,
    out: NDArray[np.uint8],
    total: NDArray[np.float32],
) -> None:  # pragma: no cover - compiled
    """Weighted means of the blocks, a block row at a time, encoded as sRGB codes into `out`.

    Each block's sums are float32, its voxels added in (z, y, x) order; the mean is
    encoded in float64 as :func:`shellvox.voxel.colour._srgb.linear_to_srgb` does (alpha clipped).
    """
    n_c = colour.shape[3]
    n_z, n_y, n_x = weight.shape
    n_ox = total.shape[2]
    sums = np.zeros((n_ox, n_c), dtype=np.float32)
    for oz in range(total.shape[0]):
        z0, z1 = oz * fz, min(n_z, oz * fz + fz)
        for oy in range(total.shape[1]):
            y0, y1 = oy * fy, min(n_y, oy * fy + fy)
            if not coloured_rows[z0:z1, y0:y1].any():  # most block rows hold no colour
                continue
            sums[:] = 0
            line = total[oz, oy]
            for z in range(z0, z1):
                for y in range(y0, y1):
                    if not coloured_rows[z, y]:
                        continue
                    row = weight[z, y]
                    for x in range(n_x):
                        w = np.float32(row[x])
                        if w == 0:
                            continue
                        ox = x // fx
                        line[ox] += w
                        for c in range(min(n_c, 3)):
                            sums[ox, c] += w * lut[colour[z, y, x, c]]
                        if n_c == 4:
                            sums[ox, 3] += w * np.float32(colour[z, y, x, 3] / 255.0)
            codes = out[oz, oy]
            for ox in range(n_ox):
                t = line[ox]
                if t > 0:
                    for c in range(n_c):
                        mean = min(max(float(sums[ox, c] / t), 0.0), 1.0)
                        if c < 3:
                            if mean <= 0.0031308:
                                mean = mean * 12.92
                            else:
                                mean = 1.055 * mean ** (1.0 / 2.4) - 0.055
                        codes[ox, c] = np.uint8(np.rint(mean * 255.0))
