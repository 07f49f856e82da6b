"""Compiled surface colour of voxels: nearest point on a given face, then its colour.

The colour layer of a printer-resolution build has 1e7 to 1e8 voxels, each needing the
barycentric coordinates of its nearest point and a colour lookup (face, vertex or
bilinear texture colour, in linear light). :class:`SurfaceColour` holds a mesh's colour
source as plain arrays and :func:`voxel_colours` does both steps in one compiled loop
over the voxels, with the arithmetic of
:func:`shellvox.voxel.geometry._nearest.closest_barycentric`, of :mod:`shellvox.voxel.colour._srgb`
and of ``shellvox.model._texture`` / ``shellvox.model._mesh.ColouredMesh.colour_at``
term for term, so the colours are those of the numpy path (tests compare them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.colour._srgb import DECODE_LUT
from shellvox.voxel.geometry import barycentric

#: ``kind`` codes.
CONSTANT, FACE, VERTEX, TEXTURE = 0, 1, 2, 3
#: Wrap codes (``wrap`` columns u, v) and filter codes.
REPEAT, CLAMP, MIRROR = 0, 1, 2
LINEAR, NEAREST = 0, 1
WRAP_CODES = {"repeat": REPEAT, "clamp": CLAMP, "mirror": MIRROR}
FILTER_CODES = {"linear": LINEAR, "nearest": NEAREST}


@dataclass(frozen=True, eq=False)
class SurfaceColour:
    """A mesh's colour source as arrays (one of face, vertex, texture or a constant).

    Attributes
    ----------
    kind : int
        ``CONSTANT``, ``FACE``, ``VERTEX`` or ``TEXTURE``.
    rgba : (F, 3, 4) uint8
        sRGB + alpha per face corner (``VERTEX``), per face in corner 0 (``FACE``), or
        the constant in ``[0, 0]`` (``CONSTANT``; shape ``(1, 3, 4)``).
    corner_uv : (F, 3, 2) float64
        Texture coordinates per corner, ``v`` up (``TEXTURE``; else ``(0, 3, 2)``).
    face_material : (F,) int64
        Material per face (``TEXTURE``; else empty).
    pixels : (P,) uint8
        Every material's image, sRGB + alpha, rows from the top, one after the other.
    image : (M, 3) int64
        Per material: offset into ``pixels``, height, width (height 0: no image).
    wrap : (M, 2) int64
        Wrap codes along u and v.
    filter : (M,) int64
        Filter codes.
    factor : (M, 4) float64
        Linear RGB + alpha factor.
    """

    kind: int
    rgba: NDArray[np.uint8]
    corner_uv: NDArray[np.float64]
    face_material: NDArray[np.int64]
    pixels: NDArray[np.uint8]
    image: NDArray[np.int64]
    wrap: NDArray[np.int64]
    filter: NDArray[np.int64]
    factor: NDArray[np.float64]


def voxel_colours(
    points_mm: NDArray[np.float64],
    face_ids: NDArray[np.int64],
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    colour: SurfaceColour,
) -> NDArray[np.uint8]:
    """Return the sRGB + alpha ``(N, 4) uint8`` of each point's nearest point on its face.

    Parameters
    ----------
    points_mm : (N, 3) float64, mm
        Voxel centres ``(x, y, z)``.
    face_ids : (N,) int64
        The nearest face of each point.
    vertices : (V, 3) float64, mm
        Mesh vertices.
    faces : (F, 3) int64
        Mesh faces.
    colour : SurfaceColour
        The colour source.
    """
    out = np.empty((len(face_ids), 4), dtype=np.uint8)
    textures = _Textures(
        colour.pixels, colour.image, colour.wrap, colour.filter, colour.factor, DECODE_LUT
    )
    source = _Source(colour.kind, colour.rgba, colour.corner_uv, colour.face_material, textures)
    _colour_kernel(
        np.ascontiguousarray(points_mm, dtype=np.float64),
        np.ascontiguousarray(face_ids, dtype=np.int64),
        _Mesh(vertices, faces),
        source,
        _Encoding(_THRESHOLD, _BIN_START),
        out,
    )
    return out


class _Mesh(NamedTuple):
    vertices: NDArray[np.float64]  # (V, 3) mm
    faces: NDArray[np.int64]  # (F, 3)


class _Textures(NamedTuple):
    """The materials' images as :func:`_sample` reads them (see :class:`SurfaceColour`)."""

    pixels: NDArray[np.uint8]
    image: NDArray[np.int64]
    wrap: NDArray[np.int64]
    filter_mode: NDArray[np.int64]
    factor: NDArray[np.float64]
    decode: NDArray[np.float64]  # (256,) sRGB code to linear


class _Source(NamedTuple):
    """The colour source as the compiled kernel reads it (see :class:`SurfaceColour`)."""

    kind: int
    rgba: NDArray[np.uint8]
    corner_uv: NDArray[np.float64]
    face_material: NDArray[np.int64]
    textures: _Textures


class _Encoding(NamedTuple):
    """Linear to 8-bit sRGB, the tables of :func:`_encode_tables`."""

    threshold: NDArray[np.float64]
    start: NDArray[np.int64]


@kernel
def _wrap(index: int, size: int, mode: int) -> int:
    """Map a texel index into ``[0, size)`` (``shellvox.model._texture._wrap``)."""
    if 0 <= index < size:
        return index
    if mode == REPEAT:
        return index % size
    if mode == MIRROR:
        period = index % (2 * size)
        return period if period < size else 2 * size - 1 - period
    return min(max(index, 0), size - 1)


@kernel
def _encode_exact(linear: float) -> int:
    """8-bit sRGB code of a linear value (:func:`shellvox.voxel.colour._srgb.encode_uint8`)."""
    x = min(max(linear, 0.0), 1.0)
    srgb = x * 12.92 if x <= 0.0031308 else 1.055 * x ** (1.0 / 2.4) - 0.055
    return int(np.rint(srgb * 255.0))


#: Bins of the encoding table over ``[0, 1]``.
ENCODE_BINS = 4096


@kernel
def _encode_tables() -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Thresholds of :func:`_encode_exact` and the code at the start of each bin.

    ``threshold[c]`` is the smallest float64 whose code is ``c`` (found by bisection over
    the float64 values, which are ordered like their bit patterns for ``x >= 0``), so
    the code of ``x`` is the number of thresholds ``<= x``, less one: exactly what the
    formula gives, for a monotonic formula (checked in the tests), without its ``pow``.
    """
    threshold = np.zeros(257)
    threshold[256] = np.inf
    bits = np.zeros(1, dtype=np.float64)
    view = bits.view(np.int64)
    one = np.array([1.0]).view(np.int64)[0]
    for code in range(1, 256):
        lo, hi = 0, one  # _encode_exact(lo) < code <= _encode_exact(hi)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            view[0] = mid
            if _encode_exact(bits[0]) >= code:
                hi = mid
            else:
                lo = mid
        view[0] = hi
        threshold[code] = bits[0]
    start = np.zeros(ENCODE_BINS + 1, dtype=np.int64)
    code = 0
    for b in range(ENCODE_BINS + 1):
        x = b / ENCODE_BINS
        while threshold[code + 1] <= x:
            code += 1
        start[b] = code
    return threshold, start


_THRESHOLD, _BIN_START = _encode_tables()


@kernel
def _encode(linear: float, threshold: NDArray[np.float64], start: NDArray[np.int64]) -> int:
    """8-bit sRGB code of a linear value, from the tables of :func:`_encode_tables`."""
    x = min(max(linear, 0.0), 1.0)
    code = start[int(x * ENCODE_BINS)]
    while threshold[code + 1] <= x:
        code += 1
    return int(code)


@kernel
def _colour_kernel(
    points: NDArray[np.float64],
    face_ids: NDArray[np.int64],
    mesh: _Mesh,
    source: _Source,
    encoding: _Encoding,
    out: NDArray[np.uint8],
) -> None:
    """Fill ``out (N, 4)`` with the colour of each point's nearest point on its face."""
    vertices, faces = mesh.vertices, mesh.faces
    kind, rgba, corner_uv = source.kind, source.rgba, source.corner_uv
    face_material, textures, decode = source.face_material, source.textures, source.textures.decode
    threshold, start = encoding.threshold, encoding.start
    linear = np.empty(4)
    weights = np.empty(3)
    for n in range(len(face_ids)):
        f = face_ids[n]
        if kind == CONSTANT:
            for ch in range(4):
                out[n, ch] = rgba[0, 0, ch]
            continue
        if kind == FACE:
            for ch in range(4):
                out[n, ch] = rgba[f, 0, ch]
            continue
        fa, fb, fc = faces[f, 0], faces[f, 1], faces[f, 2]
        v, w = barycentric(
            points[n, 0], points[n, 1], points[n, 2],
            vertices[fa, 0], vertices[fa, 1], vertices[fa, 2],
            vertices[fb, 0], vertices[fb, 1], vertices[fb, 2],
            vertices[fc, 0], vertices[fc, 1], vertices[fc, 2],
        )  # fmt: skip
        weights[0], weights[1], weights[2] = 1.0 - v - w, v, w
        if kind == VERTEX:
            for ch in range(4):
                value = 0.0
                for corner in range(3):
                    code = rgba[f, corner, ch]
                    texel = decode[code] if ch < 3 else code / 255.0
                    value += weights[corner] * texel
                linear[ch] = value
        else:
            u = weights[0] * corner_uv[f, 0, 0] + weights[1] * corner_uv[f, 1, 0]
            u += weights[2] * corner_uv[f, 2, 0]
            t = weights[0] * corner_uv[f, 0, 1] + weights[1] * corner_uv[f, 1, 1]
            t += weights[2] * corner_uv[f, 2, 1]
            m = face_material[f]
            _sample(u, t, m, textures, linear)
        for ch in range(3):
            out[n, ch] = _encode(linear[ch], threshold, start)
        out[n, 3] = int(np.rint(min(max(linear[3], 0.0), 1.0) * 255.0))


@kernel
def _sample(u: float, t: float, m: int, textures: _Textures, linear: NDArray[np.float64]) -> None:
    """Linear RGBA of material ``m`` at ``(u, v = t)``.

    See ``shellvox.model._texture.Material.sample``.
    """
    pixels, image, wrap = textures.pixels, textures.image, textures.wrap
    filter_mode, factor, decode = textures.filter_mode, textures.factor, textures.decode
    offset, height, width = image[m, 0], image[m, 1], image[m, 2]
    if height == 0:
        for ch in range(4):
            linear[ch] = factor[m, ch]
        return
    x = u * width - 0.5
    y = (1.0 - t) * height - 0.5
    if filter_mode[m] == NEAREST:
        col = _wrap(math.floor(x + 0.5), width, wrap[m, 0])
        row = _wrap(math.floor(y + 0.5), height, wrap[m, 1])
        base = offset + (row * width + col) * 4
        for ch in range(4):
            code = pixels[base + ch]
            texel = decode[code] if ch < 3 else code / 255.0
            linear[ch] = texel * factor[m, ch]
        return
    x0 = math.floor(x)
    y0 = math.floor(y)
    fx = x - x0
    fy = y - y0
    c0 = _wrap(int(x0), width, wrap[m, 0])
    c1 = _wrap(int(x0) + 1, width, wrap[m, 0])
    r0 = _wrap(int(y0), height, wrap[m, 1])
    r1 = _wrap(int(y0) + 1, height, wrap[m, 1])
    i00 = offset + (r0 * width + c0) * 4
    i01 = offset + (r0 * width + c1) * 4
    i10 = offset + (r1 * width + c0) * 4
    i11 = offset + (r1 * width + c1) * 4
    w00, w01 = (1 - fx) * (1 - fy), fx * (1 - fy)
    w10, w11 = (1 - fx) * fy, fx * fy
    for ch in range(4):
        if ch < 3:
            t00, t01 = decode[pixels[i00 + ch]], decode[pixels[i01 + ch]]
            t10, t11 = decode[pixels[i10 + ch]], decode[pixels[i11 + ch]]
        else:
            t00, t01 = pixels[i00 + ch] / 255.0, pixels[i01 + ch] / 255.0
            t10, t11 = pixels[i10 + ch] / 255.0, pixels[i11 + ch] / 255.0
        value = t00 * w00 + t01 * w01 + t10 * w10 + t11 * w11
        linear[ch] = value * factor[m, ch]
