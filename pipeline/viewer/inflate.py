"""Random access into zlib streams: chosen bytes of a stream without inflating the rest.

A voxel slice along y or x needs one row or one column of every TIFF page, and a
page is one deflate stream (RFC 1951), which has no random access: zlib must write
out every byte before the ones asked for (0.4 GB/s on voxel pages). This decoder reads
the stream's *symbols* instead and writes no output: a run of literals is kept as
the literal bytes, a match whose distance is 1 to 4 bytes (the runs of a voxel page;
:mod:`voxel.deflate` writes no other kind) as its repeating pattern of 1 to 4 bytes,
taken from the last 4 bytes of output, which are tracked, and a longer-distance match
(zlib's general matches) as a reference back. A byte at position ``p`` is then read
from the symbol that holds ``p``, following references back until a literal or a
pattern. The cost is per symbol, not per byte: a page of long runs (a layer index
page) decodes hundreds of times faster than zlib inflates it.

Huffman decoding follows Mark Adler's ``puff.c`` (the reference inflater in zlib's
``contrib/puff``): canonical codes decoded bit by bit from per-length counts.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

#: Symbol kinds: literal bytes (and copies from further back), a short periodic match.
_LIT, _PAT = 0, 1

#: Base length and extra bits of length symbols 257..285 (RFC 1951 section 3.2.5).
_LEN_BASE = np.array(
    [3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99,
     115, 131, 163, 195, 227, 258], dtype=np.int64)  # fmt: skip
_LEN_EXTRA = np.array(
    [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0],
    dtype=np.int64)  # fmt: skip
_DIST_BASE = np.array(
    [1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025,
     1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577], dtype=np.int64)  # fmt: skip
_DIST_EXTRA = np.array(
    [0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12,
     12, 13, 13], dtype=np.int64)  # fmt: skip
#: Bits of the lookup tables of the literal/length and distance codes (longer codes
#: are decoded bit by bit).
_TABLE_BITS = 10
#: Order of the code-length code lengths in a dynamic block header.
_CL_ORDER = np.array(
    [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15], dtype=np.int64
)

#: Failures, by code (see :data:`FAILURES`).
FAILURES = {
    1: "not a zlib stream (bad header or preset dictionary)",
    2: "the stream ends early",
    3: "invalid block type or stored length",
    4: "invalid Huffman code",
    5: "a match reaches back before the stream's start",
    6: "a position asked for lies past the stream's end",
    7: "the stream inflates to more bytes than expected",
}


class InflateError(ValueError):
    """A stream is not valid zlib data, or is shorter than the bytes asked of it."""


def pick_bytes(
    data: NDArray[np.uint8],
    stream_bounds: NDArray[np.int64],
    wanted: NDArray[np.int64],
    wanted_bounds: NDArray[np.int64],
    *,
    max_inflated: int,
) -> NDArray[np.uint8]:
    """Return chosen bytes of the inflated content of many zlib streams.

    Parameters
    ----------
    data : (B,) uint8
        The zlib streams back to back.
    stream_bounds : (S + 1,) int64
        Stream ``s`` is ``data[stream_bounds[s]:stream_bounds[s + 1]]``.
    wanted : (N,) int64
        Byte positions in the inflated streams, ascending within each stream.
    wanted_bounds : (S + 1,) int64
        The positions of stream ``s`` are ``wanted[wanted_bounds[s]:wanted_bounds[s + 1]]``
        (any order; ascending is fastest).
    max_inflated : int
        Bytes a stream may inflate to (a TIFF strip's size); more is an error.

    Returns
    -------
    (N,) uint8
        The inflated byte at each wanted position.

    Raises
    ------
    InflateError
        A stream is invalid, or shorter than a position asked of it.

    Examples
    --------
    >>> import zlib
    >>> raw = bytes(range(200)) * 50
    >>> packed = np.frombuffer(zlib.compress(raw), np.uint8)
    >>> wanted = np.array([0, 7, 9999])
    >>> bounds = np.array([0, len(packed)])
    >>> pick_bytes(packed, bounds, wanted, np.array([0, 3]), max_inflated=len(raw)).tolist()
    [0, 7, 199]
    """
    data = np.ascontiguousarray(data, dtype=np.uint8)
    stream_bounds = np.ascontiguousarray(stream_bounds, dtype=np.int64)
    wanted = np.ascontiguousarray(wanted, dtype=np.int64)
    wanted_bounds = np.ascontiguousarray(wanted_bounds, dtype=np.int64)
    if len(stream_bounds) != len(wanted_bounds) or len(stream_bounds) < 1:
        raise ValueError(
            f"stream_bounds and wanted_bounds must both be (S + 1,), got "
            f"{stream_bounds.shape} and {wanted_bounds.shape}"
        )
    for name, bounds, size in (
        ("stream_bounds", stream_bounds, len(data)),
        ("wanted_bounds", wanted_bounds, len(wanted)),
    ):
        if bounds[0] < 0 or bounds[-1] > size or np.any(np.diff(bounds) < 0):
            raise ValueError(f"{name} must ascend within 0..{size}, got {bounds}")
    if len(stream_bounds) == 1:
        return np.zeros(0, dtype=np.uint8)
    out = np.zeros(len(wanted), dtype=np.uint8)
    # at most one symbol per bit (a 1-bit code); literals: at most the inflated size
    longest = int(np.diff(stream_bounds).max())
    capacity = 8 * longest + 8
    status = _pick_all(data, stream_bounds, wanted, wanted_bounds, out, capacity, max_inflated)
    if status[0] != 0:
        raise InflateError(f"stream {status[1]}: {FAILURES.get(int(status[0]), 'failed')}")
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _pick_all(
    data: NDArray[np.uint8],
    stream_bounds: NDArray[np.int64],
    wanted: NDArray[np.int64],
    wanted_bounds: NDArray[np.int64],
    out: NDArray[np.uint8],
    capacity: int,
    max_inflated: int,
) -> NDArray[np.int64]:
    """Decode each stream's symbols and read its wanted bytes; return ``[code, stream]``."""
    starts = np.empty(capacity, dtype=np.int64)
    lengths = np.empty(capacity, dtype=np.int64)
    kinds = np.empty(capacity, dtype=np.uint8)
    infos = np.empty(capacity, dtype=np.int64)
    lits = np.empty(max_inflated, dtype=np.uint8)
    status = np.zeros(2, dtype=np.int64)
    for s in range(len(stream_bounds) - 1):
        w0, w1 = wanted_bounds[s], wanted_bounds[s + 1]
        if w0 == w1:
            continue
        result = _symbols(
            data, stream_bounds[s], stream_bounds[s + 1], starts, lengths, kinds, infos, lits
        )
        n_symbols, total = result[0], result[1]
        if n_symbols < 0:
            status[0] = -n_symbols
            status[1] = s
            return status
        m = 0
        for i in range(w0, w1):
            p = wanted[i]
            if p < 0 or p >= total:
                status[0] = 6
                status[1] = s
                return status
            if p < starts[m]:  # not ascending: search again
                m = _find(p, m + 1, starts)
            while starts[m] + lengths[m] <= p:
                m += 1
            out[i] = _value(p, m, starts, kinds, infos, lits)
    return status


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _find(p: int, hi: int, starts: NDArray[np.int64]) -> int:
    """Index of the symbol holding position ``p`` among symbols ``0 .. hi - 1``."""
    lo = 0
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if starts[mid] <= p:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _value(
    p: int,
    m: int,
    starts: NDArray[np.int64],
    kinds: NDArray[np.uint8],
    infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
) -> int:
    """Return the inflated byte at ``p``, held by symbol ``m``."""
    offset = p - starts[m]
    info = infos[m]
    if kinds[m] == _LIT:
        return int(lits[info + offset])
    period = info & 0xFF
    return int((info >> (8 * (1 + offset % period))) & 0xFF)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _need(data: NDArray[np.uint8], st: NDArray[np.int64], n: int) -> bool:
    """Make ``n`` bits available in the bit buffer; False when the stream ends."""
    while st[3] < n:
        if st[0] >= st[1]:
            return False
        st[2] |= np.int64(data[st[0]]) << st[3]
        st[0] += 1
        st[3] += 8
    return True


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _bits(data: NDArray[np.uint8], st: NDArray[np.int64], n: int) -> int:
    """Take ``n`` bits (LSB first); -1 when the stream ends."""
    if not _need(data, st, n):
        return -1
    value = st[2] & ((1 << n) - 1)
    st[2] >>= n
    st[3] -= n
    return int(value)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _decode(
    data: NDArray[np.uint8], st: NDArray[np.int64], count: NDArray[np.int64],
    symbol: NDArray[np.int64],
) -> int:  # fmt: skip
    """Decode one symbol of a canonical Huffman code (puff's ``decode``); < 0 on failure."""
    code = 0
    first = 0
    index = 0
    for length in range(1, 16):
        if st[3] == 0 and not _need(data, st, 1):
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
def _construct(
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
def _dynamic_tables(
    data: NDArray[np.uint8], st: NDArray[np.int64], lcount: NDArray[np.int64],
    lsymbol: NDArray[np.int64], dcount: NDArray[np.int64], dsymbol: NDArray[np.int64],
    ltable: NDArray[np.int64], dtable: NDArray[np.int64],
) -> int:  # fmt: skip
    """Read a dynamic block's code tables (puff's ``dynamic``); 0 or a failure code."""
    nlen = _bits(data, st, 5) + 257
    ndist = _bits(data, st, 5) + 1
    ncode = _bits(data, st, 4) + 4
    if ncode < 4 or nlen < 257 or ndist < 1:
        return 2
    if nlen > 286 or ndist > 30:
        return 3
    lengths = np.zeros(320, dtype=np.int64)
    for index in range(ncode):
        value = _bits(data, st, 3)
        if value < 0:
            return 2
        lengths[_CL_ORDER[index]] = value
    ccount = np.zeros(16, dtype=np.int64)
    csymbol = np.zeros(19, dtype=np.int64)
    if _construct(lengths, 19, ccount, csymbol) != 0:
        return 4
    for index in range(19):
        lengths[index] = 0
    index = 0
    while index < nlen + ndist:
        sym = _decode(data, st, ccount, csymbol)
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
            extra = _bits(data, st, 2)
            repeat = 3 + extra
        elif sym == 17:
            previous = 0
            extra = _bits(data, st, 3)
            repeat = 3 + extra
        else:
            previous = 0
            extra = _bits(data, st, 7)
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
    err = _construct(lengths, nlen, lcount, lsymbol)
    if err < 0 or (err > 0 and nlen - lcount[0] != 1):
        return 4
    err = _construct(lengths[nlen:], ndist, dcount, dsymbol)
    if err < 0 or (err > 0 and ndist - dcount[0] != 1):
        return 4
    _table(lengths, nlen, lcount, ltable)
    _table(lengths[nlen:], ndist, dcount, dtable)
    return 0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _fixed_lengths() -> NDArray[np.int64]:
    """Code lengths of the fixed codes (RFC 1951 section 3.2.6): 288 literal/length, 30."""
    lengths = np.zeros(318, dtype=np.int64)
    lengths[:144] = 8
    lengths[144:256] = 9
    lengths[256:280] = 7
    lengths[280:288] = 8
    lengths[288:] = 5
    return lengths


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _table(
    lengths: NDArray[np.int64], n: int, count: NDArray[np.int64], table: NDArray[np.int64]
) -> None:
    """Fill the lookup ``table`` (``symbol << 4 | length`` by the next bits; 0: longer code).

    ``count`` must hold the number of codes of each length (from :func:`_construct`).
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
def _long_code(bits: int, count: NDArray[np.int64], symbol: NDArray[np.int64]) -> int:
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _symbols(
    data: NDArray[np.uint8], start: int, stop: int, starts: NDArray[np.int64],
    lengths: NDArray[np.int64], kinds: NDArray[np.uint8], infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
) -> tuple[int, int]:  # fmt: skip
    """Decode the symbols of one zlib stream; return ``(n_symbols, inflated size)``.

    ``n_symbols`` is minus a failure code (:data:`FAILURES`) when the stream is invalid.
    Symbol ``n`` covers inflated bytes ``starts[n] .. starts[n] + lengths[n] - 1``:
    ``_LIT`` reads ``lits[infos[n]:]``; ``_PAT`` repeats ``infos[n] >> 8`` (bytes, low
    first) with period ``infos[n] & 0xFF``.
    """
    if stop - start < 2:
        return -2, 0
    cmf = int(data[start])
    flg = int(data[start + 1])
    if (cmf & 0x0F) != 8 or (cmf * 256 + flg) % 31 != 0 or (flg & 0x20) != 0:
        return -1, 0
    st = np.zeros(4, dtype=np.int64)  # byte position, stop, bit buffer, bits in it
    st[0] = start + 2
    st[1] = stop
    lcount = np.zeros(16, dtype=np.int64)
    lsymbol = np.zeros(288, dtype=np.int64)
    dcount = np.zeros(16, dtype=np.int64)
    dsymbol = np.zeros(30, dtype=np.int64)
    ltable = np.zeros(1 << _TABLE_BITS, dtype=np.int64)
    dtable = np.zeros(1 << _TABLE_BITS, dtype=np.int64)
    fixed = _fixed_lengths()
    mask = (1 << _TABLE_BITS) - 1
    n = 0  # symbols
    n_lits = 0
    total = 0  # inflated bytes so far
    last = 0  # the last 4 inflated bytes, the latest in the low byte
    final = 0
    while final == 0:
        final = _bits(data, st, 1)
        kind = _bits(data, st, 2)
        if kind < 0:
            return -2, 0
        if kind == 0:  # stored: byte aligned LEN, NLEN, then LEN bytes
            st[2] = 0
            st[3] = 0
            if st[0] + 4 > stop:
                return -2, 0
            size = int(data[st[0]]) | (int(data[st[0] + 1]) << 8)
            check = int(data[st[0] + 2]) | (int(data[st[0] + 3]) << 8)
            if size != (~check & 0xFFFF):
                return -3, 0
            st[0] += 4
            if st[0] + size > stop:
                return -2, 0
            if total + size > len(lits):
                return -7, 0
            if size == 0:
                continue
            if n > 0 and kinds[n - 1] == _LIT:
                lengths[n - 1] += size
            else:
                starts[n] = total
                lengths[n] = size
                kinds[n] = _LIT
                infos[n] = n_lits
                n += 1
            for k in range(size):
                byte = int(data[st[0] + k])
                lits[n_lits] = byte
                n_lits += 1
                last = ((last << 8) | byte) & 0xFFFFFFFF
            st[0] += size
            total += size
            continue
        if kind == 1:
            _construct(fixed, 288, lcount, lsymbol)
            _construct(fixed[288:], 30, dcount, dsymbol)
            _table(fixed, 288, lcount, ltable)
            _table(fixed[288:], 30, dcount, dtable)
        elif kind == 2:
            err = _dynamic_tables(data, st, lcount, lsymbol, dcount, dsymbol, ltable, dtable)
            if err != 0:
                return -err, 0
        else:
            return -3, 0
        pos = st[0]
        buf = st[2]
        held = st[3]  # bits in buf
        while True:
            while held <= 48 and pos < stop:
                buf |= np.int64(data[pos]) << held
                pos += 1
                held += 8
            entry = ltable[buf & mask]
            if entry == 0:
                entry = _long_code(buf, lcount, lsymbol)
            used = entry & 15
            if used == 0:
                return -4, 0
            if used > held:
                return -2, 0
            buf >>= used
            held -= used
            sym = entry >> 4
            if sym < 256:  # a literal: extends the run of literals before it
                if total >= len(lits):
                    return -7, 0
                if n > 0 and kinds[n - 1] == _LIT:
                    lengths[n - 1] += 1
                else:
                    starts[n] = total
                    lengths[n] = 1
                    kinds[n] = _LIT
                    infos[n] = n_lits
                    n += 1
                lits[n_lits] = sym
                n_lits += 1
                total += 1
                last = ((last << 8) | sym) & 0xFFFFFFFF
                continue
            if sym == 256:
                break
            sym -= 257
            if sym >= 29:
                return -4, 0
            used = _LEN_EXTRA[sym]
            if used > held:
                return -2, 0
            length = _LEN_BASE[sym] + (buf & ((1 << used) - 1))
            buf >>= used
            held -= used
            entry = dtable[buf & mask]
            if entry == 0:
                entry = _long_code(buf, dcount, dsymbol)
            used = entry & 15
            if used == 0 or (entry >> 4) >= 30:
                return -4, 0
            if used > held:
                return -2, 0
            buf >>= used
            held -= used
            dsym = entry >> 4
            used = _DIST_EXTRA[dsym]
            if used > held:
                return -2, 0
            distance = _DIST_BASE[dsym] + (buf & ((1 << used) - 1))
            buf >>= used
            held -= used
            if distance > total:
                return -5, 0
            if total + length > len(lits):
                return -7, 0
            if distance <= 4:
                # the pattern: the last `distance` bytes, oldest first
                if distance == 1:
                    pattern = last & 0xFF
                else:
                    pattern = 0
                    for j in range(distance):
                        pattern |= ((last >> (8 * (distance - 1 - j))) & 0xFF) << (8 * j)
                if (
                    n > 0
                    and kinds[n - 1] == _PAT
                    and (infos[n - 1] & 0xFF) == distance
                    and lengths[n - 1] >= distance
                ):
                    lengths[n - 1] += length  # the same periodic run goes on
                else:
                    starts[n] = total
                    lengths[n] = length
                    kinds[n] = _PAT
                    infos[n] = distance | (pattern << 8)
                    n += 1
                if distance == 1:
                    last = pattern * 0x01010101 if length >= 4 else (
                        ((last << (8 * length)) | (pattern * 0x01010101 >> (8 * (4 - length))))
                        & 0xFFFFFFFF
                    )
                else:
                    phase = length % distance  # the pattern index of the byte after the run
                    new_last = 0
                    for age in range(4, 0, -1):  # oldest of the last four first
                        if age <= length:
                            j = phase - age
                            while j < 0:
                                j += distance
                            byte = (pattern >> (8 * j)) & 0xFF
                        else:
                            byte = (last >> (8 * (age - length - 1))) & 0xFF
                        new_last = (new_last << 8) | byte
                    last = new_last
            else:
                q = total - distance
                m = _find(q, n, starts)
                period = infos[m] & 0xFF
                if (
                    kinds[m] == _PAT
                    and q + min(distance, length) <= starts[m] + lengths[m]
                    and distance % period == 0
                ):
                    # a copy of a periodic run: the run goes on (zlib's long runs)
                    if m == n - 1 and starts[m] + lengths[m] == total:
                        lengths[m] += length
                    else:
                        pattern = infos[m] >> 8
                        phase = (total - starts[m]) % period
                        rotated = 0
                        for j in range(period):
                            byte = (pattern >> (8 * ((phase + j) % period))) & 0xFF
                            rotated |= byte << (8 * j)
                        starts[n] = total
                        lengths[n] = length
                        kinds[n] = _PAT
                        infos[n] = period | (rotated << 8)
                        n += 1
                    new_last = 0
                    for age in range(4, 0, -1):
                        if age <= length:
                            byte = _value(total + length - age, n - 1, starts, kinds, infos, lits)
                        else:
                            byte = (last >> (8 * (age - length - 1))) & 0xFF
                        new_last = (new_last << 8) | byte
                    last = new_last
                    total += length
                    continue
                # otherwise kept as literals, copied from its sources
                base = n_lits
                k = 0
                while k < length:
                    if k >= distance:  # overlapping: bytes of this copy, `distance` at a time
                        chunk = min(length - k, distance)
                        for j in range(chunk):
                            lits[base + k + j] = lits[base + k + j - distance]
                    else:
                        while starts[m] + lengths[m] <= q:
                            m += 1
                        offset = q - starts[m]
                        chunk = min(starts[m] + lengths[m] - q, distance - k, length - k)
                        info = infos[m]
                        if kinds[m] == _LIT:
                            for j in range(chunk):
                                lits[base + k + j] = lits[info + offset + j]
                        else:
                            period = info & 0xFF
                            for j in range(chunk):
                                shift = 8 * (1 + (offset + j) % period)
                                lits[base + k + j] = (info >> shift) & 0xFF
                        q += chunk
                    k += chunk
                n_lits += length
                if n > 0 and kinds[n - 1] == _LIT:
                    lengths[n - 1] += length
                else:
                    starts[n] = total
                    lengths[n] = length
                    kinds[n] = _LIT
                    infos[n] = base
                    n += 1
                for k in range(max(0, length - 4), length):
                    last = ((last << 8) | int(lits[base + k])) & 0xFFFFFFFF
            total += length
        # give back the whole bytes read ahead: the bit reader continues at the byte
        st[0] = pos - held // 8
        st[2] = buf & ((1 << (held % 8)) - 1)
        st[3] = held % 8
    if final < 0:
        return -2, 0
    return n, total
