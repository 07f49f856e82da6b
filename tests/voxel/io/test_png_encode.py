"""PNG bytes from arrays, decoded by Pillow."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

import shellvox.voxel.io._png_encode as png_encode
from shellvox.voxel.io import encode_png


@pytest.mark.parametrize(
    ("shape", "mode"),
    [((1, 1), "L"), ((5, 3), "L"), ((7, 4, 3), "RGB"), ((1, 9, 4), "RGBA"), ((64, 33, 4), "RGBA")],
)
@pytest.mark.parametrize("level", [None, 0, 1, 9])
def test_png_round_trip(shape, mode, level):
    rng = np.random.default_rng(level or 0)
    pixels = rng.integers(0, 256, shape).astype(np.uint8)
    pixels[: shape[0] // 2] = 7  # runs as well as noise
    with Image.open(io.BytesIO(encode_png(pixels, level=level))) as image:
        image.load()
        assert image.format == "PNG" and image.mode == mode
        assert image.size == (shape[1], shape[0])
        np.testing.assert_array_equal(np.asarray(image), pixels)


def test_png_density_and_bad_input():
    data = encode_png(np.zeros((2, 3, 4), np.uint8), pixels_per_metre=(23622, 11811))
    with Image.open(io.BytesIO(data)) as image:
        assert image.info["dpi"] == pytest.approx((600.0, 300.0), abs=0.01)
    with pytest.raises(ValueError, match=r"image must be uint8 .* got float32 \(2, 3, 4\)"):
        encode_png(np.zeros((2, 3, 4), np.float32))
    with pytest.raises(ValueError, match=r"got uint8 \(2, 3, 2\)"):
        encode_png(np.zeros((2, 3, 2), np.uint8))
    with pytest.raises(ValueError, match=r"zlib level 0\.\.9, got 10"):
        encode_png(np.zeros((2, 3), np.uint8), level=10)


def test_png_data_split_over_several_idat_chunks(monkeypatch):
    monkeypatch.setattr(png_encode, "_IDAT_BYTES", 100)
    pixels = np.random.default_rng(1).integers(0, 256, (40, 30, 3)).astype(np.uint8)
    data = encode_png(pixels)
    assert data.count(b"IDAT") > 10
    with Image.open(io.BytesIO(data)) as image:
        np.testing.assert_array_equal(np.asarray(image), pixels)


@pytest.mark.parametrize(("samples", "mode"), [(1, "L"), (3, "RGB"), (4, "RGBA")])
@pytest.mark.parametrize("bottom_up", [False, True])
def test_indexed_png_is_the_lookup_of_its_indices(samples, mode, bottom_up):
    """Read back by Pillow: the picture is numpy's ``lut[indices]``, flipped if bottom up."""
    rng = np.random.default_rng(samples)
    lut = rng.integers(0, 256, (256, samples)).astype(np.uint8)
    indices = rng.integers(0, 256, (37, 29)).astype(np.uint8)
    indices[:10] = 3
    expected = lut[indices[::-1] if bottom_up else indices]
    if samples == 1:
        expected = expected[..., 0]
    data = png_encode.encode_indexed_png(indices, lut, bottom_up=bottom_up)
    assert data == encode_png(expected)
    with Image.open(io.BytesIO(data)) as image:
        assert image.mode == mode
        np.testing.assert_array_equal(np.asarray(image), expected)


def test_indexed_png_bad_input():
    lut = np.zeros((256, 4), np.uint8)
    with pytest.raises(ValueError, match=r"indices must be uint8 \(H, W\), got int64"):
        png_encode.encode_indexed_png(np.zeros((2, 3), np.int64), lut)
    with pytest.raises(ValueError, match=r"lut must be uint8 \(256, S\), got uint8 \(255, 4\)"):
        png_encode.encode_indexed_png(np.zeros((2, 3), np.uint8), lut[:255])
    with pytest.raises(ValueError, match="lut must have 1, 3 or 4 samples, got 2"):
        png_encode.encode_indexed_png(np.zeros((2, 3), np.uint8), lut[:, :2])
