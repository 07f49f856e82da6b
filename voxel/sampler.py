"""A reproducible sample of voxels per layer, gathered slab by slab."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.grid import GridSpec


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
        counts = np.bincount(flat_layers, minlength=256)
        # The ranks (among the slab's voxels of that layer, in flat order) to keep: all,
        # or a draw without replacement, as ``rng.choice`` of the positions would draw.
        ranks = []
        for layer in range(1, self.n_layers + 1):
            n = int(counts[layer])
            if n > self.per_slab:
                ranks.append(np.sort(rng.choice(n, size=self.per_slab, replace=False)))
            else:
                ranks.append(np.arange(n))
        starts = np.zeros(257, dtype=np.int64)
        starts[2 : self.n_layers + 2] = np.cumsum([len(r) for r in ranks])
        starts[self.n_layers + 2 :] = starts[self.n_layers + 1]
        where = _positions(flat_layers, np.concatenate(ranks).astype(np.int64), starts)
        index = np.stack(np.unravel_index(where, layers.shape), axis=1).astype(np.int64)
        index[:, 0] += z_start
        for layer in range(1, self.n_layers + 1):
            self._index.append(index[starts[layer] : starts[layer + 1]])
            self._layers.append(flat_layers[where[starts[layer] : starts[layer + 1]]])

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
        """Return the centres ``(N, 3) float64 mm`` ``(x, y, z)`` and layers ``(N,) uint8``."""
        if not self._index:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.uint8)
        index = np.concatenate(self._index)
        return self.grid.index_to_world(index), np.concatenate(self._layers)


@kernel
def _positions(
    flat: NDArray[np.uint8], ranks: NDArray[np.int64], starts: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Positions in `flat` of the ``ranks[starts[v]:starts[v + 1]]``-th voxels of value v.

    One pass over the slab; each value's ranks are sorted.
    """
    out = np.empty(len(ranks), dtype=np.int64)
    seen = np.zeros(256, dtype=np.int64)
    following = starts[:256].copy()
    for i in range(len(flat)):
        value = flat[i]
        j = following[value]
        if j < starts[value + 1] and ranks[j] == seen[value]:
            out[j] = i
            following[value] = j + 1
        seen[value] += 1
    return out
