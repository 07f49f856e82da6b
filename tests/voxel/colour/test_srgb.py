"""sRGB transfer and CIELAB of shellvox.voxel.colour._srgb against colour-science."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from shellvox.voxel.colour import (
    DECODE_LUT,
    codes_to_linear,
    decode_uint8,
    encode_uint8,
    linear_to_lab,
    linear_to_srgb,
    srgb8_to_lab,
    srgb_to_lab,
    srgb_to_linear,
)

CODES = np.arange(256, dtype=np.uint8)


def test_transfer_matches_colour_science():
    values = np.random.default_rng(0).random(10_000)
    np.testing.assert_allclose(srgb_to_linear(values), colour.cctf_decoding(values, "sRGB"))
    np.testing.assert_allclose(linear_to_srgb(values), colour.cctf_encoding(values, "sRGB"))
    np.testing.assert_allclose(DECODE_LUT, colour.models.eotf_sRGB(CODES / 255.0), atol=1e-12)


def test_uint8_round_trip_through_linear_is_exact():
    values = np.stack(np.meshgrid(np.arange(256), 0, 0, 255, indexing="ij"), -1).reshape(-1, 4)
    values = values.astype(np.uint8)
    np.testing.assert_array_equal(encode_uint8(decode_uint8(values)), values)
    np.testing.assert_allclose(decode_uint8(values)[:, 3], 1.0)


def test_float32_codes_match_colour_science():
    linear = codes_to_linear(CODES)
    assert linear.dtype == np.float32
    np.testing.assert_allclose(linear, colour.models.eotf_sRGB(CODES / 255.0), atol=2e-7)
    with pytest.raises(ValueError, match="uint8"):
        codes_to_linear(np.array([0.5]))


def test_lab_matches_colour_science():
    rgb = np.random.default_rng(1).integers(0, 256, (500, 3), dtype=np.uint8)
    expected = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(rgb / 255.0))
    np.testing.assert_allclose(srgb8_to_lab(rgb), expected, atol=1e-9)
    np.testing.assert_allclose(srgb_to_lab(rgb / 255.0), expected, atol=1e-9)
    np.testing.assert_allclose(linear_to_lab(srgb_to_linear(rgb / 255.0)), expected, atol=1e-9)
    np.testing.assert_allclose(srgb8_to_lab(rgb.reshape(20, 25, 3)), expected.reshape(20, 25, 3))
