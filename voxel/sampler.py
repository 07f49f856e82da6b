"""A reproducible sample of voxels per layer, gathered slab by slab."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from voxel.grid import GridSpec


class LayerSampler:
    """Keep up to about ``total`` voxels of the layers ``1..K+1``, spread over the slabs.

    Each slab contributes up to ``ceil(total / (n_slabs * (K + 1)))`` voxels of each
    layer, drawn without replacement with a generator seeded by the slab's first row, so
    the sample does not depend on the order slabs are added in.

    Parameters
    ----------
    grid : GridSpec
        The voxel grid.
    n_bands : int
        Number of shell bands ``K``.
    n_slabs : int
        Number of slabs that will be added.
    total : int
        Target sample size.
    """

    def __init__(self, grid: GridSpec, n_bands: int, n_slabs: int, total: int = 20_000):
        self.grid = grid
        self.n_layers = n_bands + 1
        self.per_slab = max(1, math.ceil(total / (max(1, n_slabs) * self.n_layers)))
        self._index: list[NDArray[np.int64]] = []
        self._layers: list[NDArray[np.uint8]] = []

    def add(self, z_start: int, layers: NDArray[np.uint8]) -> None:
        """Sample the slab ``layers (Zs, Y, X) uint8`` whose first row is ``z_start``."""
        rng = np.random.default_rng(z_start)
        flat_layers = layers.reshape(-1)
        for layer in range(1, self.n_layers + 1):
            where = np.flatnonzero(flat_layers == layer)
            if len(where) > self.per_slab:
                where = np.sort(rng.choice(where, size=self.per_slab, replace=False))
            index = np.stack(np.unravel_index(where, layers.shape), axis=1).astype(np.int64)
            index[:, 0] += z_start
            self._index.append(index)
            self._layers.append(flat_layers[where])

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
        """Return the centres ``(N, 3) float64 mm`` ``(x, y, z)`` and layers ``(N,) uint8``."""
        if not self._index:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.uint8)
        index = np.concatenate(self._index)
        return self.grid.index_to_world(index), np.concatenate(self._layers)
