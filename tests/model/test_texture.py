"""Texture sampling: texel centres, wrap rules, filtering in linear light."""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.model import Material
from shellvox.voxel.colour import decode_uint8, encode_uint8


def _material(wrap=("repeat", "repeat"), filt="linear"):
    image = np.zeros((4, 8, 4), dtype=np.uint8)
    image[..., 0] = (np.arange(8) * 30)[None, :]
    image[..., 1] = (np.arange(4) * 60)[:, None]
    image[..., 3] = 255
    return Material("m", image=image, wrap=wrap, filter=filt)


def _texel_uv(row, col, height=4, width=8):
    return np.array([[(col + 0.5) / width, 1 - (row + 0.5) / height]])


@pytest.mark.parametrize("filt", ["linear", "nearest"])
def test_texel_centres_return_the_texel(filt):
    material = _material(filt=filt)
    for row in range(4):
        for col in range(8):
            got = encode_uint8(material.sample(_texel_uv(row, col)))[0]
            np.testing.assert_array_equal(got, material.image[row, col])


def test_bilinear_midpoint_is_linear_light_mean():
    material = _material()
    uv = (_texel_uv(1, 2) + _texel_uv(1, 3)) / 2
    expected = (decode_uint8(material.image[1, 2]) + decode_uint8(material.image[1, 3])) / 2
    np.testing.assert_allclose(material.sample(uv)[0], expected, atol=1e-12)


def test_wrap_rules():
    uv = _texel_uv(1, 1)
    repeat = _material()
    np.testing.assert_allclose(repeat.sample(uv + np.array([1.0, -2.0])), repeat.sample(uv))
    clamp = _material(wrap=("clamp", "clamp"))
    np.testing.assert_allclose(
        clamp.sample(np.array([[1.7, 0.5]])), clamp.sample(np.array([[1 - 0.5 / 8, 0.5]]))
    )
    mirror = _material(wrap=("mirror", "mirror"))
    # Mirrored repeat: u = 1 + d samples like u = 1 - d.
    np.testing.assert_allclose(
        mirror.sample(np.array([[1.0 + 0.3 / 8, 0.6]])),
        mirror.sample(np.array([[1.0 - 0.3 / 8, 0.6]])),
        atol=1e-12,
    )
