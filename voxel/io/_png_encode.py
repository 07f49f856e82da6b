"""PNG bytes from uint8 arrays, fast: every row unfiltered, one zlib stream (serialisation only).

Why not :meth:`PIL.Image.Image.save`? For RGB and RGBA images Pillow's PNG encoder
always chooses a row filter adaptively (it tries each filter on every row) and offers no
way to turn that off. On a 1322 x 1176 RGBA printer slice (a background, a solid core and
a halftoned skin) Pillow took 90-110 ms at ``compress_level=1`` and wrote 171 kB; rows
stored unfiltered (filter type 0) and deflated at level 1 took 28 ms and 141 kB: slices
of material keys are runs of identical pixels, which zlib finds without a filter, and
halftone noise is not made more predictable by one. At printer resolution a model has
thousands of slices, so that factor decides whether the job adds seconds or minutes.

The format is PNG 1.2 (ISO/IEC 15948): signature, ``IHDR``, an optional ``pHYs``, the
``IDAT`` data (a zlib stream of rows, each prefixed by its filter type byte), ``IEND``;
each chunk is length, type, data and CRC-32. zlib releases the GIL while it compresses,
so several slices can be encoded in parallel threads. The tests read every file back
with Pillow.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.io._compression import check_level, compressobj

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: PNG colour type by samples per pixel: grey, RGB, RGBA (8 bits per sample).
_COLOUR_TYPE = {1: 0, 3: 2, 4: 6}
#: Largest chunk data the format allows (2**31 - 1); IDAT data is split below it.
_MAX_CHUNK = 2**31 - 1
_IDAT_BYTES = 1 << 26


def encode_png(
    image: NDArray[np.uint8],
    *,
    level: int | None = None,
    pixels_per_metre: tuple[int, int] | None = None,
) -> bytes:
    """Return a PNG file of `image` with unfiltered rows (see the module docstring).

    Parameters
    ----------
    image : (H, W) or (H, W, S) uint8
        Grey (``S`` = 1), RGB (3) or RGBA (4, straight alpha) samples; row 0 is the top of
        the picture.
    level : int, optional
        None (default): the fast setting (:mod:`shellvox.voxel.io._compression`); else zlib's level
        0..9.
    pixels_per_metre : (2,) int, optional
        Physical pixel density ``(x, y)`` stored in a ``pHYs`` chunk (600 dpi is 23622).

    Returns
    -------
    bytes
        The whole file.

    Examples
    --------
    >>> import io
    >>> from PIL import Image
    >>> pixels = np.arange(24, dtype=np.uint8).reshape(2, 3, 4)
    >>> back = Image.open(io.BytesIO(encode_png(pixels)))
    >>> back.mode, back.size, bool((np.asarray(back) == pixels).all())
    ('RGBA', (3, 2), True)
    """
    pixels = np.asarray(image)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    if (
        pixels.dtype != np.uint8
        or pixels.ndim != 3
        or pixels.shape[2] not in _COLOUR_TYPE
        or 0 in pixels.shape[:2]
    ):
        raise ValueError(
            f"image must be uint8 (H, W), (H, W, 3) or (H, W, 4), got {pixels.dtype} {pixels.shape}"
        )
    check_level(level)
    height, width, samples = pixels.shape
    rows = np.empty((height, 1 + width * samples), dtype=np.uint8)
    rows[:, 0] = 0  # filter type None
    rows[:, 1:] = pixels.reshape(height, width * samples)
    return _png(rows, width, samples, level, pixels_per_metre)


def encode_indexed_png(
    indices: NDArray[np.uint8],
    lut: NDArray[np.uint8],
    *,
    bottom_up: bool = False,
    level: int | None = None,
    pixels_per_metre: tuple[int, int] | None = None,
) -> bytes:
    """Return a PNG file of the pixels ``lut[indices]``, made in one compiled pass.

    What :func:`encode_png` of ``lut[indices]`` (rows reversed if `bottom_up`) writes,
    without the gathered image and its copy into rows: a printer slice of material
    indices becomes a PNG of their keys.

    Parameters
    ----------
    indices : (H, W) uint8
        Index of each pixel's row in `lut`.
    lut : (256, S) uint8
        The samples (1, 3 or 4) of each index.
    bottom_up : bool
        Row 0 of `indices` is the bottom of the picture (the last PNG row).
    level, pixels_per_metre
        As for :func:`encode_png`.
    """
    if indices.dtype != np.uint8 or indices.ndim != 2 or 0 in indices.shape:
        raise ValueError(f"indices must be uint8 (H, W), got {indices.dtype} {indices.shape}")
    if lut.dtype != np.uint8 or lut.ndim != 2 or lut.shape[0] != 256:
        raise ValueError(f"lut must be uint8 (256, S), got {lut.dtype} {lut.shape}")
    samples = lut.shape[1]
    if samples not in _COLOUR_TYPE:
        raise ValueError(f"lut must have 1, 3 or 4 samples, got {samples}")
    check_level(level)
    height, width = indices.shape
    rows = np.empty((height, 1 + width * samples), dtype=np.uint8)
    _indexed_rows(indices, np.ascontiguousarray(lut), bottom_up, rows)
    return _png(rows, width, samples, level, pixels_per_metre)


@kernel
def _indexed_rows(
    indices: NDArray[np.uint8], lut: NDArray[np.uint8], bottom_up: bool, rows: NDArray[np.uint8]
) -> None:
    """Fill ``rows (H, 1 + W * S)``: filter type 0, then ``lut[indices]`` of the row."""
    height, width = indices.shape
    samples = lut.shape[1]
    for r in range(height):
        j = height - 1 - r if bottom_up else r
        rows[r, 0] = 0
        if samples == 4:  # constant strides, which LLVM vectorises
            for i in range(width):
                k = indices[j, i]
                rows[r, 1 + 4 * i] = lut[k, 0]
                rows[r, 2 + 4 * i] = lut[k, 1]
                rows[r, 3 + 4 * i] = lut[k, 2]
                rows[r, 4 + 4 * i] = lut[k, 3]
        else:
            for i in range(width):
                k = indices[j, i]
                for c in range(samples):
                    rows[r, 1 + samples * i + c] = lut[k, c]


def _png(
    rows: NDArray[np.uint8],
    width: int,
    samples: int,
    level: int | None,
    pixels_per_metre: tuple[int, int] | None,
) -> bytes:
    """Return the PNG file of ``rows (H, 1 + W * S)``, each led by its filter type."""
    height = rows.shape[0]
    packer = compressobj(level)
    data = packer.compress(rows.data) + packer.flush()
    header = struct.pack(">IIBBBBB", width, height, 8, _COLOUR_TYPE[samples], 0, 0, 0)
    parts = [_SIGNATURE, _chunk(b"IHDR", header)]
    if pixels_per_metre is not None:
        x_ppm, y_ppm = (round(v) for v in pixels_per_metre)
        parts.append(_chunk(b"pHYs", struct.pack(">IIB", x_ppm, y_ppm, 1)))  # unit: metre
    parts += [_chunk(b"IDAT", data[i : i + _IDAT_BYTES]) for i in range(0, len(data), _IDAT_BYTES)]
    parts.append(_chunk(b"IEND", b""))
    return b"".join(parts)


def _chunk(kind: bytes, data: bytes) -> bytes:
    """Return one chunk: length, type, data, CRC-32 of type and data."""
    if len(data) > _MAX_CHUNK:
        raise ValueError(f"PNG chunk data must be < 2**31 bytes, got {len(data)}")
    crc = zlib.crc32(data, zlib.crc32(kind))
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)
