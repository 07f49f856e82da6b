"""A 3D blue-noise threshold tile by the void-and-cluster method (Ulichney 1993).

:func:`blue_noise_tile` returns a periodic ``(s, s, s)`` array holding each threshold
``(r + 0.5) / s^3``, ``r = 0 .. s^3 - 1``, exactly once, so that for every level ``t``
the voxels whose threshold is below ``t`` form an evenly spread (blue-noise) pattern
of density ``t``, also across the tile's periodic edges. Tiled over the grid by global
voxel index it gives an order-independent halftone: a voxel's threshold depends only
on its own index.

Tile size: every ``s^3`` window of an ``s``-periodic tiling holds each residue class
``(z mod s, y mod s, x mod s)`` once, so with ``s = 16`` every 16^3-voxel window of a
uniform region holds each threshold exactly once and reproduces each proportion to
within ``1 / 4096`` (the done-when asks 2 %). The price is a period of 16 voxels (on the
J750 grid 0.68 x 1.35 x 0.43 mm), which may show as a faint regular texture; a larger
tile (``tile_size`` 32) trades that for window errors of a few tenths of a percent.
The filter is isotropic in voxel index (the grid's voxels are not cubes).

Construction (deterministic for a seed on a given numpy build): a random initial
pattern of ``s^3 / 10`` points from ``numpy.random.default_rng(seed)``, relaxed by
moving the tightest cluster to the largest void until they coincide; ranks below the
initial count by removing tightest clusters, ranks above by filling largest voids
(equivalently, in phase 3, the tightest clusters of the minority zeros). Cluster and
void are judged by a periodic Gaussian filter (``sigma = 1.5`` voxels). The loop runs
once per rank (4096 for ``s = 16``, about a second); the tile is cached per
``(size, seed, sigma)``.

References
----------
R. Ulichney, "The void-and-cluster method for dither array generation", Proc. SPIE
1913, Human Vision, Visual Processing, and Digital Display IV (1993).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

#: Default tile edge in voxels (see the module for the choice).
DEFAULT_TILE = 16
#: Gaussian filter width in voxels, Ulichney's recommended 1.5.
DEFAULT_SIGMA = 1.5


def blue_noise_tile(
    size: int = DEFAULT_TILE, *, seed: int = 0, sigma: float = DEFAULT_SIGMA
) -> NDArray[np.float32]:
    """Return a periodic 3D blue-noise threshold tile.

    Parameters
    ----------
    size : int
        Tile edge ``s`` in voxels (4 .. 64).
    seed : int
        Seed of the initial random pattern; the same seed gives the same tile.
    sigma : float
        Width of the periodic Gaussian filter, voxels.

    Returns
    -------
    (s, s, s) float32, read-only
        Thresholds ``(rank + 0.5) / s^3``, each once, indexed ``[z % s, y % s, x % s]``.

    Examples
    --------
    >>> tile = blue_noise_tile(4, seed=1)
    >>> sorted(tile.ravel() * 64 - 0.5) == list(range(64))
    True
    """
    if not 4 <= size <= 64:
        raise ValueError(f"size must be 4..64 voxels, got {size}")
    if not sigma > 0:
        raise ValueError(f"sigma must be > 0, got {sigma}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    return _cached_tile(size, seed, float(sigma))


@functools.lru_cache(maxsize=8)
def _cached_tile(size: int, seed: int, sigma: float) -> NDArray[np.float32]:
    ranks = _void_and_cluster(size, seed, sigma)
    tile = ((ranks + 0.5) / ranks.size).astype(np.float32).reshape(size, size, size)
    tile.setflags(write=False)
    return tile


def _void_and_cluster(size: int, seed: int, sigma: float) -> NDArray[np.int64]:
    """Return the rank (0 .. s^3 - 1) of every cell of the ``(s, s, s)`` tile, flat."""
    n = size**3
    offset = np.minimum(np.arange(size), size - np.arange(size)).astype(np.float64)
    dz, dy, dx = np.meshgrid(offset, offset, offset, indexing="ij")
    kernel = np.exp(-(dz**2 + dy**2 + dx**2) / (2.0 * sigma**2))

    def footprint(cell: int) -> NDArray[np.float64]:
        shifted: NDArray[np.float64] = np.roll(
            kernel, np.unravel_index(cell, kernel.shape), axis=(0, 1, 2)
        ).ravel()
        return shifted

    rng = np.random.default_rng(seed)
    pattern = np.zeros(n, dtype=bool)
    pattern[rng.choice(n, size=max(1, n // 10), replace=False)] = True
    energy = np.zeros(n)
    for cell in np.flatnonzero(pattern):
        energy += footprint(int(cell))

    # relax the initial pattern: move the tightest cluster to the largest void
    for _ in range(10 * n):
        cluster = int(np.argmax(np.where(pattern, energy, -np.inf)))
        pattern[cluster] = False
        energy -= footprint(cluster)
        void = int(np.argmin(np.where(pattern, np.inf, energy)))
        pattern[void] = True
        energy += footprint(void)
        if void == cluster:
            break

    ranks = np.empty(n, dtype=np.int64)
    n_initial = int(pattern.sum())
    # phase 1: remove tightest clusters from a copy, ranks n_initial - 1 .. 0
    ones, ones_energy = pattern.copy(), energy.copy()
    for rank in range(n_initial - 1, -1, -1):
        cluster = int(np.argmax(np.where(ones, ones_energy, -np.inf)))
        ones[cluster] = False
        ones_energy -= footprint(cluster)
        ranks[cluster] = rank
    # phases 2 and 3: fill largest voids, ranks n_initial .. n - 1
    for rank in range(n_initial, n):
        void = int(np.argmin(np.where(pattern, np.inf, energy)))
        pattern[void] = True
        energy += footprint(void)
        ranks[void] = rank
    return ranks
