"""The compiled block classification and gather of the VDB encoder, against numpy."""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.voxel.io.vdb._encode import _block_stats, _Blocks

LEAF = 8


def _padded(volume: np.ndarray, fill) -> np.ndarray:
    """``(Zs, Y, X[, C])`` padded with `fill` to 8 rows and whole 8 x 8 columns."""
    pads = [(0, LEAF - volume.shape[0]), (0, -volume.shape[1] % LEAF)]
    pads += [(0, -volume.shape[2] % LEAF)] + [(0, 0)] * (volume.ndim - 3)
    return np.pad(volume, pads, constant_values=fill)


def _blocked(volume: np.ndarray) -> np.ndarray:
    """``(8, Y, X)`` -> ``(Y/8, X/8, 512)`` in the order z, y, x within the block."""
    _, n_y, n_x = volume.shape
    view = volume.reshape(LEAF, n_y // LEAF, LEAF, n_x // LEAF, LEAF)
    return view.transpose(1, 3, 0, 2, 4).reshape(n_y // LEAF, n_x // LEAF, -1)


def _rows(shape, seed):
    rng = np.random.default_rng(seed)
    layers = rng.integers(0, 4, shape).astype(np.uint8)
    layers[:, : shape[1] // 2] = 3  # constant blocks as well as mixed ones
    layers[:, :, : shape[2] // 3] = 0
    sdf = rng.normal(0, 2, shape).astype(np.float32)
    coloured = rng.random(shape) < 0.01
    materials = np.where(layers > 0, rng.integers(1, 3, shape), 0).astype(np.uint8)
    materials[:, : shape[1] // 3] = 2
    return layers, sdf, coloured, materials


@pytest.mark.parametrize("shape", [(8, 40, 48), (5, 37, 45), (8, 3, 9), (1, 8, 8)])
@pytest.mark.parametrize("with_materials", [True, False])
def test_block_stats_are_numpys_reductions_of_the_padded_blocks(shape, with_materials):
    layers, sdf, coloured, materials = _rows(shape, sum(shape))
    hw = np.float32(1.5)
    given = materials if with_materials else np.zeros((0, 0, 0), np.uint8)
    stats = _block_stats(layers, sdf, coloured, given, hw)
    inside = _blocked(_padded(layers, 0) > 0)
    values = _blocked(_padded(layers, 0))
    expected = [
        inside.any(-1), inside.all(-1), _blocked(np.abs(_padded(sdf, hw)) < hw).any(-1),
        _blocked(_padded(coloured, False)).any(-1), values.min(-1), values.max(-1),
    ]  # fmt: skip
    if with_materials:
        m = _blocked(_padded(materials, 0))
        expected += [(m > 0).any(-1), (m > 0).all(-1), m.min(-1), m.max(-1)]
    for k, want in enumerate(expected):
        np.testing.assert_array_equal(stats[..., k], want.astype(np.int32), err_msg=f"stat {k}")


@pytest.mark.parametrize("shape", [(8, 40, 48), (5, 37, 45)])
def test_gathered_leaves_are_in_openvdb_voxel_order_with_the_fill_past_the_edge(shape):
    layers, sdf, coloured, _ = _rows(shape, 7)
    rgb = np.random.default_rng(1).integers(0, 256, (*shape, 4)).astype(np.uint8)[..., :3]
    blocks = _Blocks(16)
    which = np.random.default_rng(2).random((-(-shape[1] // 8), -(-shape[2] // 8))) < 0.5
    b_y, b_x = np.nonzero(which)
    for volume, fill in ((layers, 9), (sdf, np.float32(2.5)), (coloured, True), (rgb, 7)):
        padded = _padded(volume, fill)
        got = blocks.gather(volume, which, fill)
        for n, (j, i) in enumerate(zip(b_y, b_x, strict=True)):
            block = padded[:, 8 * j : 8 * j + 8, 8 * i : 8 * i + 8]  # (z, y, x[, c])
            leaf = block.transpose(2, 1, 0, *range(3, block.ndim))  # (x, y, z[, c])
            np.testing.assert_array_equal(got[n], leaf.reshape(512, *volume.shape[3:]))
    origins = blocks.origins(which)
    np.testing.assert_array_equal(origins, np.stack([8 * b_x, 8 * b_y, np.full(len(b_y), 16)], 1))
