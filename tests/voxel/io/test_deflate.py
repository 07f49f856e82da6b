"""The run-length deflate encoder against Python's zlib (an independent inflater)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest
import tifffile

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import TiffStackWriter, pixel_bytes, zlib_compress
from shellvox.voxel.io._deflate import FIXED_BELOW, compress_segments


@pytest.mark.parametrize("period", [1, 2, 3, 4])
def test_round_trip_through_zlib(period: int) -> None:
    rng = np.random.default_rng(period)
    for _ in range(300):
        n = int(rng.integers(0, 5000))
        values = rng.integers(0, 256, n) * (rng.random(n) < rng.random())
        data = np.repeat(values, rng.integers(1, 40, n))[:n].astype(np.uint8)
        packed = zlib_compress(data, period)
        assert zlib.decompress(packed) == data.tobytes()
    noise = rng.integers(0, 256, 200_000).astype(np.uint8)  # all literals: the worst case
    assert zlib.decompress(zlib_compress(noise.tobytes(), period)) == noise.tobytes()
    with pytest.raises(ValueError, match="period"):
        zlib_compress(b"abc", 5)


def _block_type(stream: bytes) -> int:
    """BTYPE of a zlib stream's first deflate block (bits 1-2 after the 2-byte header)."""
    return (stream[2] >> 1) & 0b11


def test_segments_short_and_long_through_zlib() -> None:
    """Each segment its own stream, inflated by zlib; fixed codes below the threshold."""
    rng = np.random.default_rng(7)
    one = np.frombuffer(np.float32(1.0).tobytes(), np.uint8)
    sizes = [0, 4, 2048, 6144, FIXED_BELOW - 4, FIXED_BELOW, 3 * FIXED_BELOW]
    parts = []
    for k, size in enumerate(sizes):
        runs = np.tile(one, size // 4) if k % 2 else np.repeat(rng.integers(0, 9, size), 7)
        parts.append(np.asarray(runs[:size], dtype=np.uint8))
    raw = np.concatenate(parts)
    bounds = np.concatenate([[0], np.cumsum(sizes)])
    packed, lengths = compress_segments(raw, bounds, period=4)
    starts = np.concatenate([[0], np.cumsum(lengths)])
    for part, size, a, b in zip(parts, sizes, starts[:-1], starts[1:], strict=True):
        stream = packed[a:b].tobytes()
        assert zlib.decompress(stream) == part.tobytes()
        assert _block_type(stream) == (1 if size < FIXED_BELOW else 2)
        assert stream == zlib_compress(part, 4)  # one stream or many: the same bytes
    # a leaf of one value: a 3-bit header, not the dynamic block's 93 bytes
    leaf = np.tile(one, 512)
    assert len(zlib_compress(leaf, 4)) < len(zlib.compress(leaf.tobytes(), 9)) + 8


def test_runs_compress_like_zlib() -> None:
    page = np.zeros((1000, 1200, 3), np.uint8)
    page[300:700, 200:900] = (200, 30, 40)
    packed = zlib_compress(page, 3)
    assert zlib.decompress(packed) == page.tobytes()
    assert len(packed) < 3 * len(zlib.compress(page.tobytes(), 6))


def test_pixel_bytes_of_a_channel_slice() -> None:
    """Every view's bytes are numpy's copy of it: channel prefixes of whole rows (the
    flat path), windows, reversed rows and strided columns (the general path)."""
    slab = np.random.default_rng(0).integers(0, 256, (3, 17, 23, 4)).astype(np.uint8)
    rgba = slab[2]  # the last page: a read past the last pixel would leave the buffer
    views = [
        rgba[..., :3], rgba[..., :2], rgba[..., :1], rgba[..., 1:3], rgba[:, ::2, 0],
        rgba[2:9, 3:20, :3], rgba[::-1, :, :3], rgba[:, ::-1, :3], rgba[:1, :1, :3],
        slab[1, ..., :3], slab[2, :, :, 0], rgba,
    ]  # fmt: skip
    for view in views:
        np.testing.assert_array_equal(pixel_bytes(view), np.ascontiguousarray(view).reshape(-1))


@pytest.mark.parametrize("level", [None, 1, 9])
def test_tiff_pages_read_back(tmp_path, level: int | None) -> None:
    grid = GridSpec((0.0, 0.0, 0.0), (0.05, 0.1, 0.02), (9, 31, 40))
    rng = np.random.default_rng(3)
    colour = (rng.integers(0, 3, (9, 31, 40, 4)) * 80).astype(np.uint8)
    with TiffStackWriter(tmp_path / "c.tif", grid, samples=3, compression_level=level) as tiff:
        tiff.write_slab(colour[:4, ..., :3])
        tiff.write_slab(colour[4:, ..., :3])
    with tifffile.TiffFile(tmp_path / "c.tif") as read:
        np.testing.assert_array_equal(read.asarray(), colour[..., :3])
        assert read.pages[0].compression == 8  # deflate
        assert read.imagej_metadata["spacing"] == pytest.approx(0.02)
