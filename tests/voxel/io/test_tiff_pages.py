"""Pages compressed in slab workers give the files the writer's own compression gives.

Independent truth: the writer compressing the arrays itself, and tifffile reading back.
"""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

from shellvox.run import StackSlab, decode_chunk, encode_chunk
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import PageEncoder, TiffStackWriter
from shellvox.voxel.slab import SlabResult

GRID = GridSpec((0.0, 0.0, 0.0), (0.05, 0.1, 0.02), (11, 23, 37))


def _voxels(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    layers = np.zeros(GRID.shape_zyx, np.uint8)
    layers[:, 5:18, 8:30] = rng.integers(1, 4, size=(11, 13, 22), dtype=np.uint8)
    rgba = np.zeros((*GRID.shape_zyx, 4), np.uint8)
    rgba[layers == 1] = rng.integers(0, 256, size=(int((layers == 1).sum()), 4), dtype=np.uint8)
    materials = rng.integers(0, 7, size=GRID.shape_zyx, dtype=np.uint8)
    return layers, rgba, materials


@pytest.mark.parametrize("level", [None, 1, 6], ids=["fast", "zlib-1", "zlib-6"])
@pytest.mark.parametrize("samples", [3, 4])
def test_precompressed_pages_write_the_same_file(tmp_path, level, samples):
    layers, rgba, materials = _voxels(samples)
    encoder = PageEncoder(colour_samples=samples, level=level, materials_tif=True)
    rows = [(0, 4), (4, 9), (9, 11)]
    for name, array, stack_samples in (
        ("layers.tif", layers, 0),
        ("colour.tif", rgba[..., :samples], samples),
        ("materials.tif", materials, 0),
    ):
        own, given = tmp_path / f"own_{name}", tmp_path / f"given_{name}"
        with TiffStackWriter(own, GRID, samples=stack_samples, compression_level=level) as w:
            for start, stop in rows:
                w.write_slab(np.ascontiguousarray(array[start:stop]))
        with TiffStackWriter(given, GRID, samples=stack_samples, compression_level=level) as writer:
            for start, stop in rows:
                pages = encoder.encode(layers[start:stop], rgba[start:stop], materials[start:stop])
                writer.write_pages(pages[name])
        assert given.read_bytes() == own.read_bytes()
        assert np.array_equal(tifffile.imread(given), array)


def test_a_chunk_keeps_the_pages():
    layers, rgba, materials = _voxels(0)
    slab = SlabResult(
        0, 11, layers, rgba, np.zeros(layers.shape, np.float32), layers > 0, 0, 0, 0, 0,
        np.bincount(layers.ravel(), minlength=4).astype(np.int64),
    )  # fmt: skip
    pages = PageEncoder(3, None, True).encode(layers, rgba, materials)
    back = decode_chunk(encode_chunk(StackSlab(slab, materials, None, None, pages)))
    assert back.pages == pages
    assert decode_chunk(encode_chunk(StackSlab(slab, materials))).pages is None


def test_a_chunk_with_pages_leaves_out_what_is_not_sent():
    layers, rgba, materials = _voxels(0)
    sdf = np.linspace(-1, 1, layers.size, dtype=np.float32).reshape(layers.shape)
    slab = SlabResult(
        0, 11, layers, rgba, sdf, layers > 0, 0, 0, 0, 0,
        np.bincount(layers.ravel(), minlength=4).astype(np.int64),
    )  # fmt: skip
    pages = PageEncoder(3, None, True).encode(layers, rgba, materials)
    light = decode_chunk(encode_chunk(StackSlab(slab, materials, None, None, pages), ("layers",)))
    np.testing.assert_array_equal(light.slab.layers, layers)
    np.testing.assert_array_equal(light.materials, materials)
    assert light.pages == pages
    for name, ndim in (("rgba", 4), ("sdf", 3), ("sdf_band", 3)):
        left_out = getattr(light.slab, name)
        assert left_out.size == 0 and left_out.ndim == ndim
    # Without pages (the writers compress), every array travels whatever `send` says.
    full = decode_chunk(encode_chunk(StackSlab(slab, materials), ("layers",)))
    for name in ("layers", "rgba", "sdf", "sdf_band"):
        np.testing.assert_array_equal(getattr(full.slab, name), getattr(slab, name))
