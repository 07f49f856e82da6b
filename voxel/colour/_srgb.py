"""Colour encodings: the sRGB transfer curve (IEC 61966-2-1) and CIELAB, in one place.

Domains and ranges:

- :func:`srgb_to_linear` / :func:`linear_to_srgb`: sRGB-encoded values in ``[0, 1]``
  <-> linear light in ``[0, 1]``, float64 (the same numbers as colour-science's
  ``cctf_decoding`` / ``cctf_encoding`` for ``"sRGB"``).
- :data:`DECODE_LUT` ``(256,) float64``: the linear value of each 8-bit code (texture
  filtering and the compiled colour kernel of :mod:`shellvox.voxel.colour._surface_colour`);
  :func:`codes_to_linear` gives the float32 values of :data:`DECODE_LUT_F32`, computed
  in float32 arithmetic (VDB colour grids, separation tables).
- :func:`decode_uint8` / :func:`encode_uint8`: ``(..., 4) uint8`` sRGB + alpha <->
  ``(..., 4) float64`` linear RGB + alpha in ``[0, 1]``.
- :func:`linear_to_lab`, :func:`srgb_to_lab`, :func:`srgb8_to_lab`: CIELAB (D65, CIE 1931
  2 degree observer) through colour-science; ``L*`` in ``[0, 100]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray


def srgb_to_linear(srgb: NDArray[np.floating[Any]]) -> NDArray[np.float64]:
    """Decode sRGB-encoded values in ``[0, 1]`` to linear light in ``[0, 1]``.

    Examples
    --------
    >>> srgb_to_linear(np.array([0.0, 0.5, 1.0])).round(4).tolist()
    [0.0, 0.214, 1.0]
    """
    srgb = np.asarray(srgb, dtype=np.float64)
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(linear: NDArray[np.floating[Any]]) -> NDArray[np.float64]:
    """Encode linear light (clipped to ``[0, 1]``) to sRGB values in ``[0, 1]``."""
    linear = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(linear <= 0.0031308, linear * 12.92, 1.055 * linear ** (1.0 / 2.4) - 0.055)


#: Linear value of each 8-bit sRGB code, float64.
DECODE_LUT = srgb_to_linear(np.arange(256) / 255.0)


def _decode_f32(value: NDArray[np.float32]) -> NDArray[np.float32]:
    """Evaluate the decoding curve in float32 arithmetic."""
    linear: NDArray[np.float32] = np.where(
        value <= 0.04045, value / np.float32(12.92), ((value + 0.055) / 1.055) ** 2.4
    ).astype(np.float32)
    return linear


#: Linear value of each 8-bit sRGB code, float32 (within 2e-7 of :data:`DECODE_LUT`).
DECODE_LUT_F32 = _decode_f32(np.arange(256, dtype=np.float32) / np.float32(255.0))


def codes_to_linear(rgb: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Return linear-light values in ``[0, 1]`` (float32) of 8-bit sRGB codes (any shape).

    Examples
    --------
    >>> [round(float(v), 4) for v in codes_to_linear(np.array([0, 128, 255], np.uint8))]
    [0.0, 0.2159, 1.0]
    """
    codes = np.asarray(rgb)
    if codes.dtype != np.uint8:
        raise ValueError(f"rgb must be uint8 sRGB codes, got {codes.dtype}")
    linear: NDArray[np.float32] = DECODE_LUT_F32[codes]
    return linear


def decode_uint8(rgba: NDArray[np.uint8]) -> NDArray[np.float64]:
    """Convert ``(..., 4) uint8`` sRGB + alpha to ``(..., 4) float64`` linear RGB + alpha."""
    out = np.empty(rgba.shape, dtype=np.float64)
    out[..., :3] = DECODE_LUT[rgba[..., :3]]
    out[..., 3] = rgba[..., 3] / 255.0
    return out


def encode_uint8(linear_rgba: NDArray[np.floating[Any]]) -> NDArray[np.uint8]:
    """Convert ``(..., 4)`` linear RGB + alpha in ``[0, 1]`` to ``(..., 4) uint8`` sRGB + alpha.

    Examples
    --------
    >>> encode_uint8(np.array([0.2159, 0.2159, 0.2159, 1.0])).tolist()
    [128, 128, 128, 255]
    """
    linear_rgba = np.asarray(linear_rgba, dtype=np.float64)
    out = np.empty(linear_rgba.shape, dtype=np.float64)
    out[..., :3] = linear_to_srgb(linear_rgba[..., :3])
    out[..., 3] = np.clip(linear_rgba[..., 3], 0.0, 1.0)
    encoded: NDArray[np.uint8] = np.rint(out * 255.0).astype(np.uint8)
    return encoded


def linear_to_lab(linear: NDArray[np.floating[Any]]) -> NDArray[np.float64]:
    """Return CIELAB ``(..., 3) float64`` of linear-light sRGB ``(..., 3)`` in ``[0, 1]``.

    Examples
    --------
    >>> linear_to_lab(np.array([1.0, 1.0, 1.0])).round(1).tolist()
    [100.0, 0.0, 0.0]
    """
    import colour  # colour-science: imported on first use (about a second)

    space = colour.RGB_COLOURSPACES["sRGB"]
    xyz = colour.RGB_to_XYZ(np.asarray(linear, dtype=np.float64), space)
    return np.asarray(colour.XYZ_to_Lab(xyz, space.whitepoint), dtype=np.float64)


def lab_to_srgb8(lab: NDArray[np.floating[Any]]) -> NDArray[np.uint8]:
    """Return 8-bit sRGB ``(..., 3) uint8`` of CIELAB (D65) ``(..., 3)``, clipped to sRGB.

    Examples
    --------
    >>> lab_to_srgb8(np.array([100.0, 0.0, 0.0])).tolist()
    [255, 255, 255]
    """
    import colour

    space = colour.RGB_COLOURSPACES["sRGB"]
    xyz = colour.Lab_to_XYZ(np.asarray(lab, dtype=np.float64), space.whitepoint)
    linear = np.clip(colour.XYZ_to_RGB(xyz, space), 0.0, 1.0)
    encoded: NDArray[np.uint8] = np.rint(linear_to_srgb(linear) * 255.0).astype(np.uint8)
    return encoded


def srgb_to_lab(srgb: NDArray[np.floating[Any]]) -> NDArray[np.float64]:
    """Return CIELAB ``(..., 3) float64`` of sRGB-encoded ``(..., 3)`` in ``[0, 1]``."""
    return linear_to_lab(srgb_to_linear(srgb))


def srgb8_to_lab(rgb: NDArray[np.uint8]) -> NDArray[np.float64]:
    """Return CIELAB ``(..., 3) float64`` of 8-bit sRGB ``(..., 3) uint8``.

    Each distinct colour is converted once.
    """
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    flat = rgb.reshape(-1, 3)
    packed = flat[:, 0].astype(np.uint32) << 16 | flat[:, 1].astype(np.uint32) << 8 | flat[:, 2]
    unique, inverse = np.unique(packed, return_inverse=True)
    channels = np.stack([(unique >> 16) & 255, (unique >> 8) & 255, unique & 255], axis=1)
    lab = srgb_to_lab(channels / 255.0)
    result: NDArray[np.float64] = lab[inverse.reshape(-1)].reshape(rgb.shape)
    return result
