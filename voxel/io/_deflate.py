"""A compiled run-length zlib encoder, for the VDB leaves; and a page's bytes in TIFF order.

:func:`compress_segments` compresses many short buffers at once (the value buffers of
:mod:`shellvox.voxel.io.vdb._leaves`, ``period=4``: 4-byte values), each as its own zlib stream,
in one call of compiled code; :func:`zlib_compress` does one buffer. The TIFF and PNG
pages are compressed by :mod:`shellvox.voxel.io._compression` instead; :func:`pixel_bytes` gives
their bytes. Voxel data is mostly long runs (void, the core, one value, repeated
pixels), and zlib's general match finder spends most of its time on them. This encoder
emits one deflate block (RFC 1951) in a zlib stream (RFC 1950): at each byte it takes
the longest run-match at distance ``period`` (1, or the bytes per pixel) or 1, of 3 to
258 bytes, else a literal (zlib's ``Z_RLE`` strategy). A stream of :data:`FIXED_BELOW`
bytes or more is one "dynamic" block (RFC 1951 section 3.2.7) whose Huffman codes are
fixed in advance for such data and sent in its 93-byte header: the longest match (258
bytes) at distance 1 costs 2 bits, so runs compress about 1000:1 as with zlib's own
codes, and a literal costs 9 or 10 bits. A shorter stream (a VDB leaf: at most 6 KiB)
is one block of deflate's fixed codes (section 3.2.6; a 3-bit header; 13 bits a longest
match, 8 or 9 a literal): the dynamic header would be most of it. Any inflater (zlib,
libpng, libtiff, Java's) reads both; the tests check round trips with Python's zlib.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel


def _reverse(code: int, length: int) -> int:
    """Return ``code`` with its ``length`` bits reversed (Huffman codes go MSB first)."""
    out = 0
    for _ in range(length):
        out = (out << 1) | (code & 1)
        code >>= 1
    return out


def _canonical(lengths: list[int]) -> list[int]:
    """Canonical Huffman codes (RFC 1951 section 3.2.2) of code ``lengths``, bit-reversed."""
    top = max(lengths)
    count = [0] * (top + 1)
    for length in lengths:
        if length:
            count[length] += 1
    code, next_code = 0, [0] * (top + 2)
    for bits in range(1, top + 1):
        code = (code + count[bits - 1]) << 1
        next_code[bits] = code
    codes = [0] * len(lengths)
    for symbol, length in enumerate(lengths):
        if length:
            codes[symbol] = _reverse(next_code[length], length)
            next_code[length] += 1
    return codes


#: Code lengths of the 286 literal/length symbols: the 258-byte match 1 bit, 227 symbols
#: 9 bits, 58 (the rarer ones: literals 227..255, end of block, the other lengths) 10
#: bits, a complete code (Kraft sum 1) as inflaters require.
_LITERAL_LENGTHS = [9] * 227 + [10] * 58 + [1]
#: Distance codes: distance 1 in 1 bit, 3 (RGB pixels) in 2, 4 codes of 6, 24 of 7 bits.
_DISTANCE_LENGTHS = [1, 6, 2, 6, 6, 6] + [7] * 24
#: Code-length alphabet (lengths 1, 2, 6, 7, 9, 10 used): 2 and 3 bits, complete.
_CL_LENGTHS = {1: 3, 2: 3, 6: 3, 7: 3, 9: 2, 10: 2}
_CL_ORDER = [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15]


def _header() -> tuple[int, int]:
    """Bits ``(value, count)`` of the block header: BFINAL, BTYPE = 2 and the codes."""
    cl_lengths = [_CL_LENGTHS.get(symbol, 0) for symbol in range(19)]
    cl_codes = _canonical(cl_lengths)
    fields: list[tuple[int, int]] = [(1, 1), (2, 2), (286 - 257, 5), (30 - 1, 5), (19 - 4, 4)]
    fields += [(cl_lengths[symbol], 3) for symbol in _CL_ORDER]
    for length in _LITERAL_LENGTHS + _DISTANCE_LENGTHS:
        fields.append((cl_codes[length], cl_lengths[length]))
    value = count = 0
    for field, width in fields:
        value |= field << count
        count += width
    return value, count


def _literal_codes() -> tuple[NDArray[np.uint32], NDArray[np.uint8]]:
    """Bit-reversed codes and lengths of the literal/length symbols."""
    codes = np.array(_canonical(_LITERAL_LENGTHS), dtype=np.uint32)
    return codes, np.array(_LITERAL_LENGTHS, dtype=np.uint8)


def _length_table() -> NDArray[np.int64]:
    """Per match length 3..258: symbol, extra bits and extra value, ``(259, 3)``."""
    base = [3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83,
            99, 115, 131, 163, 195, 227, 258]  # fmt: skip
    extra = [0] * 8 + [1] * 4 + [2] * 4 + [3] * 4 + [4] * 4 + [5] * 4 + [0]
    table = np.zeros((259, 3), dtype=np.int64)
    for length in range(3, 259):
        index = 28 if length == 258 else max(i for i, b in enumerate(base[:28]) if b <= length)
        table[length] = (257 + index, extra[index], length - base[index])
    return table


class _Tables(NamedTuple):
    """The fixed code of every stream, as the compiled encoder reads it."""

    codes: NDArray[np.uint32]  # (286,) literal/length codes
    code_lengths: NDArray[np.uint8]  # (286,) their lengths in bits
    lengths: NDArray[np.int64]  # (259, 3) per match length: symbol, extra bits, extra value
    distance_codes: NDArray[np.uint32]  # (30,) distance codes
    distance_lengths: NDArray[np.uint8]  # (30,) their lengths in bits
    header: NDArray[np.uint8]  # the dynamic block's header, bits packed little-endian
    header_bits: int  # bits of the header


def _tables() -> _Tables:
    codes, code_lengths = _literal_codes()
    header_value, header_bits = _header()
    return _Tables(
        codes,
        code_lengths,
        _length_table(),
        np.array(_canonical(_DISTANCE_LENGTHS), dtype=np.uint32),
        np.array(_DISTANCE_LENGTHS, dtype=np.uint8),
        np.frombuffer(header_value.to_bytes(256, "little"), dtype=np.uint8).copy(),
        header_bits,
    )


_TABLES = _tables()

#: Streams shorter than this (bytes) are one block of deflate's fixed codes: the dynamic
#: block's header (737 bits) pays for itself after about 67 longest matches (11 bits
#: each), some 17 KB of runs.
FIXED_BELOW = 16384


def _fixed_tables() -> _Tables:
    """Return the fixed codes of RFC 1951 section 3.2.6 and their header (BFINAL, BTYPE 1)."""
    literal_lengths = [8] * 144 + [9] * 112 + [7] * 24 + [8] * 8
    return _Tables(
        np.array(_canonical(literal_lengths), dtype=np.uint32),
        np.array(literal_lengths, dtype=np.uint8),
        _length_table(),
        np.array(_canonical([5] * 30), dtype=np.uint32),
        np.full(30, 5, dtype=np.uint8),
        np.frombuffer((0b011).to_bytes(256, "little"), dtype=np.uint8).copy(),
        3,
    )


_FIXED_TABLES = _fixed_tables()


def zlib_compress(data: bytes | NDArray[np.uint8], period: int = 1) -> bytes:
    """Return ``data`` as a zlib stream (runs as matches at distance ``period`` or 1).

    Parameters
    ----------
    data : bytes or (N,) uint8
        The bytes to encode (any array is taken as its raw bytes, C order).
    period : int
        Bytes per pixel, 1 to 4: runs of equal pixels are found at this distance.

    Examples
    --------
    >>> import zlib
    >>> raw = bytes(1000) + b"abcabcabc" + bytes(500)
    >>> packed = zlib_compress(raw)
    >>> zlib.decompress(packed) == raw, len(packed) < len(raw) // 10
    (True, True)
    """
    if not 1 <= period <= 4:
        raise ValueError(f"period must be 1..4, got {period}")
    if isinstance(data, bytes):
        raw = np.frombuffer(data, dtype=np.uint8)
    else:
        raw = np.ascontiguousarray(data).reshape(-1).view(np.uint8)
    # worst case: header, 10 bits a byte (all literals), end of block, Adler-32
    header_bytes = _TABLES.header_bits // 8
    out = np.empty(2 + header_bytes + 1 + (10 * len(raw) + 7) // 8 + 2 + 4 + 8, np.uint8)
    tables = _FIXED_TABLES if len(raw) < FIXED_BELOW else _TABLES
    size = _encode(raw, period, tables, out)
    return out[:size].tobytes()


@kernel
def _match(raw: NDArray[np.uint8], i: int, distance: int, n: int) -> int:
    """Length (<= 258) of the run at ``i`` repeating the bytes ``distance`` back."""
    if i < distance:
        return 0
    limit = min(258, n - i)
    length = 0
    while length < limit and raw[i + length] == raw[i + length - distance]:
        length += 1
    return length


@kernel
def _encode(raw: NDArray[np.uint8], period: int, tables: _Tables, out: NDArray[np.uint8]) -> int:
    """Write the zlib stream of ``raw`` into ``out``; return its size."""
    codes, code_lengths, lengths, distance_codes, distance_lengths, header, header_bits = tables
    n = len(raw)
    out[0] = 0x78  # deflate, 32 KiB window
    out[1] = 0x01  # fastest; (0x78 * 256 + 0x01) % 31 == 0
    pos = 2
    whole = header_bits // 8
    for k in range(whole):
        out[pos] = header[k]
        pos += 1
    n_bits = header_bits - 8 * whole
    bits = np.uint64(header[whole]) & np.uint64((1 << n_bits) - 1)
    i = 0
    while i < n:
        best = _match(raw, i, period, n)
        distance = period
        if period != 1 and best < 258:
            run = _match(raw, i, 1, n)
            if run > best:
                best, distance = run, 1
        if best >= 3:
            symbol, extra, value = lengths[best, 0], lengths[best, 1], lengths[best, 2]
            bits |= np.uint64(codes[symbol]) << np.uint64(n_bits)
            n_bits += code_lengths[symbol]
            bits |= np.uint64(value) << np.uint64(n_bits)
            n_bits += extra
            bits |= np.uint64(distance_codes[distance - 1]) << np.uint64(n_bits)
            n_bits += distance_lengths[distance - 1]
            i += best
        else:
            symbol = raw[i]
            bits |= np.uint64(codes[symbol]) << np.uint64(n_bits)
            n_bits += code_lengths[symbol]
            i += 1
        while n_bits >= 8:
            out[pos] = np.uint8(bits & np.uint64(0xFF))
            pos += 1
            bits >>= np.uint64(8)
            n_bits -= 8
    bits |= np.uint64(codes[256]) << np.uint64(n_bits)  # end of block
    n_bits += code_lengths[256]
    while n_bits > 0:
        out[pos] = np.uint8(bits & np.uint64(0xFF))
        pos += 1
        bits >>= np.uint64(8)
        n_bits -= 8
    a, b = _adler32(raw)
    out[pos] = (b >> 8) & 0xFF
    out[pos + 1] = b & 0xFF
    out[pos + 2] = (a >> 8) & 0xFF
    out[pos + 3] = a & 0xFF
    return pos + 4


@kernel
def _adler32(raw: NDArray[np.uint8]) -> tuple[int, int]:
    """Adler-32 sums ``(a, b)`` of ``raw`` (RFC 1950), modulo taken every 5552 bytes."""
    a = 1
    b = 0
    n = len(raw)
    start = 0
    while start < n:
        stop = min(n, start + 5552)
        for i in range(start, stop):
            a += raw[i]
            b += a
        a %= 65521
        b %= 65521
        start = stop
    return a, b


def pixel_bytes(page: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Return a ``(Y, X[, C])`` uint8 page as contiguous bytes (compiled strided copy).

    numpy copies a channel slice such as ``rgba[..., :3]`` byte by byte at about
    0.4 GB/s. Such a slice of whole contiguous rows (the colour pages) is copied from a
    flat view of its parent's bytes, about 10 times faster; other strides by a general loop.
    """
    if page.flags.c_contiguous:
        return page.reshape(-1)
    if page.ndim == 2:
        page = page[:, :, None]
    n_y, n_x, n_c = page.shape
    s_y, s_x, s_c = page.strides
    if s_c == 1 and n_c < s_x and s_y == s_x * n_x and n_y * n_x > 0:
        # The bytes from the first sample to the last one read, all inside the parent.
        span = s_y * n_y - (s_x - n_c)
        flat = np.lib.stride_tricks.as_strided(page, shape=(span,), strides=(1,), writeable=False)
        out = np.empty(n_y * n_x * n_c, dtype=np.uint8)
        _copy_samples(flat, s_x, n_c, out)
        return out
    out = np.empty(page.shape, dtype=np.uint8)
    _copy_pixels(page, out)
    return out.reshape(-1)


@kernel
def _copy_samples(flat: NDArray[np.uint8], step: int, n_c: int, out: NDArray[np.uint8]) -> None:
    """Copy the first ``n_c`` of every ``step`` bytes of ``flat`` into ``out``."""
    n = len(out) // n_c
    if n_c == 3 and step == 4:  # RGB of RGBA: constant strides, which LLVM vectorises (7x)
        for k in range(n):
            out[3 * k] = flat[4 * k]
            out[3 * k + 1] = flat[4 * k + 1]
            out[3 * k + 2] = flat[4 * k + 2]
    else:
        for k in range(n):
            for c in range(n_c):
                out[n_c * k + c] = flat[step * k + c]


@kernel
def _copy_pixels(page: NDArray[np.uint8], out: NDArray[np.uint8]) -> None:
    """Copy ``page (Y, X, C)`` (any strides) into the contiguous ``out``."""
    n_y, n_x, n_c = page.shape
    for j in range(n_y):
        for i in range(n_x):
            for c in range(n_c):
                out[j, i, c] = page[j, i, c]


def compress_segments(
    raw: NDArray[np.uint8], bounds: NDArray[np.int64], period: int = 1
) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
    """Compress each segment ``raw[bounds[i]:bounds[i + 1]]`` as its own zlib stream.

    One compiled call for many small buffers (e.g. the 512-voxel leaves of a VDB grid),
    where a Python loop over them would cost microseconds each.

    Returns
    -------
    packed : (P,) uint8
        The streams back to back.
    lengths : (n,) int64
        Length of each stream.
    """
    raw = np.ascontiguousarray(raw).reshape(-1).view(np.uint8)
    bounds = np.asarray(bounds, dtype=np.int64)
    sizes = np.diff(bounds)
    worst = 2 + _TABLES.header_bits // 8 + 1 + (10 * sizes + 7) // 8 + 2 + 4 + 8
    out = np.empty(int(worst.sum()), dtype=np.uint8)
    lengths = np.zeros(len(sizes), dtype=np.int64)
    room = np.concatenate([[0], np.cumsum(worst)]).astype(np.int64)
    used = _encode_segments(raw, bounds, room, period, _TABLES, _FIXED_TABLES, out, lengths)
    return out[:used], lengths


@kernel
def _encode_segments(
    raw: NDArray[np.uint8],
    bounds: NDArray[np.int64],
    room: NDArray[np.int64],
    period: int,
    tables: _Tables,
    fixed: _Tables,
    out: NDArray[np.uint8],
    packed_lengths: NDArray[np.int64],
) -> int:
    """Encode each segment into ``out`` back to back; return the bytes used."""
    pos = 0
    for n in range(len(bounds) - 1):
        segment = raw[bounds[n] : bounds[n + 1]]
        chosen = fixed if len(segment) < FIXED_BELOW else tables
        size = _encode(segment, period, chosen, out[pos : pos + room[n + 1] - room[n]])
        packed_lengths[n] = size
        pos += size
    return pos
