"""The layer sampler's one-pass draw against the direct one (positions, then rng.choice)."""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.sampler import LayerSampler

GRID = GridSpec((1.0, -2.0, 0.5), (0.1, 0.2, 0.05), (30, 40, 50))


def _reference(sampler: LayerSampler, z_start: int, layers: np.ndarray) -> list[np.ndarray]:
    """Each layer's kept voxel indices ``(n, 3)`` (z, y, x), drawn from all its positions."""
    rng = np.random.default_rng(z_start)
    flat = layers.reshape(-1)
    kept = []
    for layer in range(1, sampler.n_layers + 1):
        where = np.flatnonzero(flat == layer)
        if len(where) > sampler.per_slab:
            where = np.sort(rng.choice(where, size=sampler.per_slab, replace=False))
        index = np.stack(np.unravel_index(where, layers.shape), axis=1)
        index[:, 0] += z_start
        kept.append(index)
    return kept


@pytest.mark.parametrize("total", [50, 2_000, 10**6])
def test_one_pass_draw_keeps_the_same_voxels(total):
    rng = np.random.default_rng(5)
    layers = rng.integers(0, 5, GRID.shape_zyx, dtype=np.uint8)
    layers[:, :8] = 4  # a core of runs
    layers[3:6] = 0  # rows without any layer
    sampler = LayerSampler(GRID, n_bands=3, n_slabs=3, total=total)
    expected = []
    for z0 in (0, 10, 20):
        sampler.add(z0, layers[z0 : z0 + 10])
        expected += _reference(sampler, z0, layers[z0 : z0 + 10])
    points, sampled = sampler.samples()
    index = np.concatenate(expected)
    np.testing.assert_array_equal(points, GRID.index_to_world(index))
    np.testing.assert_array_equal(sampled, layers[tuple(index.T)])
    assert set(np.unique(sampled)) <= {1, 2, 3, 4}
