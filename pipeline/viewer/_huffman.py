"""Huffman codes of deflate streams (RFC 1951): bit reading and code tables, compiled.

Follows Mark Adler's ``puff.c`` (the reference inflater in zlib's ``contrib/puff``) for
the code tables, with a lookup table for codes up to :data:`TABLE_BITS` bits; used by
:mod:`pipeline.viewer._inflate`. Bit state ``st``: ``(next byte, end, bit buffer, bits
in the buffer)``. Functions return 0 on success or a failure code of
:data:`pipeline.viewer._inflate.FAILURES`.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

#: Bits of the lookup tables of the literal/length and distance codes (longer codes
#: are decoded bit by bit).
TABLE_BITS = 10
#: Order of the code-length code lengths in a dynamic block header.
CL_ORDER = np.array(
    [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15], dtype=np.int64
)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def need(data: NDArray[np.uint8], st: NDArray[np.int64], n: int) -> bool:
    """Make ``n`` bits available in the bit buffer; False when the stream ends."""
    while st[3] < n:
        if st[0] >= st[1]:
            return False
        st[2] |= np.int64(data[st[0]]) << st[3]
        st[0] += 1
        st[3] += 8
    return True


@numba.njit(cache=True, nogil=True, error_model="numpy")
def bits(data: NDArray[np.uint8], st: NDArray[np.int64], n: int) -> int:
    """Take ``n`` bits (LSB first); -1 when the stream ends."""
    if not need(data, st, n):
        return -1
    value = st[2] & ((1 << n) - 1)
    st[2] >>= n
    st[3] -= n
    return int(value)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def decode_symbol(
    data: NDArray[np.uint8],
    st: NDArray[np.int64],
    count: NDArray[np.int64],
    symbol: NDArray[np.int64],
) -> int:
    """Decode one symbol of a canonical Huffman code (puff's ``decode``); < 0 on failure."""
    code = 0
    first = 0
    index = 0
    for length in range(1, 16):
        if st[3] == 0 and not need(data, st, 1):
            return -2
        code |= int(st[2] & 1)
        st[2] >>= 1
        st[3] -= 1
        n = count[length]
        if code - n < first:
            return int(symbol[index + code - first])
        index += n
        first += n
        first <<= 1
        code <<= 1
    return -4


@numba.njit(cache=True, nogil=True, error_model="numpy")
def construct(
    lengths: NDArray[np.int64], n: int, count: NDArray[np.int64], symbol: NDArray[np.int64]
) -> int:
    """Build decoding tables from code lengths (puff's ``construct``); < 0 if over-subscribed."""
    for length in range(16):
        count[length] = 0
    for s in range(n):
        count[lengths[s]] += 1
    if count[0] == n:
        return 0
    left = 1
    for length in range(1, 16):
        left <<= 1
        left -= count[length]
        if left < 0:
            return int(left)
    offs = np.zeros(16, dtype=np.int64)
    for length in range(1, 15):
        offs[length + 1] = offs[length] + count[length]
    for s in range(n):
        if lengths[s] != 0:
            symbol[offs[lengths[s]]] = s
            offs[lengths[s]] += 1
    return left


@numba.njit(cache=True, nogil=True, error_model="numpy")
def dynamic_tables(
    data: NDArray[np.uint8],
    st: NDArray[np.int64],
    lcount: NDArray[np.int64],
    lsymbol: NDArray[np.int64],
    dcount: NDArray[np.int64],
    dsymbol: NDArray[np.int64],
    ltable: NDArray[np.int64],
    dtable: NDArray[np.int64],
) -> int:
    """Read a dynamic block's code tables (puff's ``dynamic``); 0 or a failure code."""
    nlen = bits(data, st, 5) + 257
    ndist = bits(data, st, 5) + 1
    ncode = bits(data, st, 4) + 4
    if ncode < 4 or nlen < 257 or ndist < 1:
        return 2
    if nlen > 286 or ndist > 30:
        return 3
    lengths = np.zeros(320, dtype=np.int64)
    for index in range(ncode):
        value = bits(data, st, 3)
        if value < 0:
            return 2
        lengths[CL_ORDER[index]] = value
    ccount = np.zeros(16, dtype=np.int64)
    csymbol = np.zeros(19, dtype=np.int64)
    if construct(lengths, 19, ccount, csymbol) != 0:
        return 4
    for index in range(19):
        lengths[index] = 0
    index = 0
    while index < nlen + ndist:
        sym = decode_symbol(data, st, ccount, csymbol)
        if sym < 0:
            return 2 if sym == -2 else 4
        if sym < 16:
            lengths[index] = sym
            index += 1
            continue
        repeat = 0
        if sym == 16:
            if index == 0:
                return 4
            previous = lengths[index - 1]
            extra = bits(data, st, 2)
            repeat = 3 + extra
        elif sym == 17:
            previous = 0
            extra = bits(data, st, 3)
            repeat = 3 + extra
        else:
            previous = 0
            extra = bits(data, st, 7)
            repeat = 11 + extra
        if extra < 0:
            return 2
        if index + repeat > nlen + ndist:
            return 4
        for _ in range(repeat):
            lengths[index] = previous
            index += 1
    if lengths[256] == 0:
        return 4
    err = construct(lengths, nlen, lcount, lsymbol)
    if err < 0 or (err > 0 and nlen - lcount[0] != 1):
        return 4
    err = construct(lengths[nlen:], ndist, dcount, dsymbol)
    if err < 0 or (err > 0 and ndist - dcount[0] != 1):
        return 4
    table(lengths, nlen, lcount, ltable)
    table(lengths[nlen:], ndist, dcount, dtable)
    return 0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def fixed_lengths() -> NDArray[np.int64]:
    """Code lengths of the fixed codes (RFC 1951 section 3.2.6): 288 literal/length, 30."""
    lengths = np.zeros(318, dtype=np.int64)
    lengths[:144] = 8
    lengths[144:256] = 9
    lengths[256:280] = 7
    lengths[280:288] = 8
    lengths[288:] = 5
    return lengths


@numba.njit(cache=True, nogil=True, error_model="numpy")
def table(
    lengths: NDArray[np.int64], n: int, count: NDArray[np.int64], table: NDArray[np.int64]
) -> None:
    """Fill the lookup ``table`` (``symbol << 4 | length`` by the next bits; 0: longer code).

    ``count`` must hold the number of codes of each length (from :func:`construct`).
    """
    table[:] = 0
    next_code = np.zeros(16, dtype=np.int64)
    code = 0
    for length in range(1, 16):
        code = (code + (count[length - 1] if length > 1 else 0)) << 1
        next_code[length] = code
    size = len(table)
    for s in range(n):
        length = lengths[s]
        if length == 0:
            continue
        code = next_code[length]
        next_code[length] += 1
        if (1 << length) > size:
            continue
        reverse = 0
        for _ in range(length):
            reverse = (reverse << 1) | (code & 1)
            code >>= 1
        for k in range(reverse, size, 1 << length):
            table[k] = (s << 4) | length


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def long_code(bits: int, count: NDArray[np.int64], symbol: NDArray[np.int64]) -> int:
    """Decode a code longer than the table from the next ``bits``: ``symbol << 4 | length``."""
    code = 0
    first = 0
    index = 0
    for length in range(1, 16):
        code |= (bits >> (length - 1)) & 1
        n = count[length]
        if code - n < first:
            return int((symbol[index + code - first] << 4) | length)
        index += n
        first += n
        first <<= 1
        code <<= 1
    return 0
