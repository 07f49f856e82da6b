"""Random access into zlib streams: chosen bytes of a stream without inflating all of it.

A voxel slice along y or x needs one row or one column of every TIFF page, and a
page is a deflate stream (RFC 1951), which has no random access: zlib writes out every
byte before the ones asked for (0.4 GB/s on voxel pages). :func:`decode` reads a
stream's *symbols* instead and writes no output: a run of literals is kept as its
bytes, a match at a distance of 1 to 4 bytes (the runs of a voxel page;
:mod:`voxel.deflate` writes no other kind) as its repeating pattern of 1 to 4 bytes, and
a match from further back (zlib's general matches) as copies of the symbols it
repeats. The result, :class:`Symbols`, is a run-length description of the inflated
bytes, about as large as the compressed stream; :func:`pick` reads any bytes of it by
binary search. Decoding costs per symbol, not per byte: a page of long runs decodes
several times faster than zlib inflates it, and a decoded page answers any row or
column at once.

Huffman decoding follows Mark Adler's ``puff.c`` (the reference inflater in zlib's
``contrib/puff``) for the code tables, with a lookup table for codes up to 10 bits.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

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
#: Runs shorter than this are kept as literal bytes (a run symbol takes 16 bytes).
_SHORT_RUN = 16
#: Order of the code-length code lengths in a dynamic block header.
_CL_ORDER = np.array(
    [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15], dtype=np.int64
)

#: Failures, by code.
FAILURES = {
    1: "not a zlib stream (bad header or preset dictionary)",
    2: "the stream ends early",
    3: "invalid block type or stored length",
    4: "invalid Huffman code",
    5: "a match reaches back before the stream's start",
    6: "a position asked for lies past the stream's end",
    7: "the stream inflates to more bytes than expected",
    8: "more symbols than room (internal: retried with more)",
}


class InflateError(ValueError):
    """A stream is not valid zlib data, or is shorter than the bytes asked of it."""


class Symbols(NamedTuple):
    """The inflated bytes of one stream as runs (see the module docstring).

    Attributes
    ----------
    starts : (n + 1,) int64
        Symbol ``m`` covers inflated bytes ``starts[m] .. starts[m + 1] - 1``;
        ``starts[n]`` is the inflated size.
    infos : (n,) int64
        ``>= 0``: literal bytes from ``lits[infos[m]]`` on; ``< 0``: a repeating pattern,
        ``x = -infos[m] - 1`` holds its period ``x & 0xFF`` (1 to 4) and its bytes
        ``x >> 8`` (the first in the low byte).
    lits : (L,) uint8
        Literal bytes.
    """

    starts: NDArray[np.int64]
    infos: NDArray[np.int64]
    lits: NDArray[np.uint8]

    @property
    def size(self) -> int:
        """Inflated size in bytes."""
        return int(self.starts[-1])

    @property
    def nbytes(self) -> int:
        """Memory held, in bytes."""
        return int(self.starts.nbytes + self.infos.nbytes + self.lits.nbytes)


def decode(stream: bytes | NDArray[np.uint8], *, max_inflated: int) -> Symbols:
    """Decode a zlib stream into :class:`Symbols`.

    Parameters
    ----------
    stream : bytes or (B,) uint8
        One zlib stream (RFC 1950).
    max_inflated : int
        Bytes the stream may inflate to (a TIFF strip's size); more is an error.

    Raises
    ------
    InflateError
        The stream is invalid or inflates to more than ``max_inflated`` bytes.
    """
    data = np.frombuffer(stream, dtype=np.uint8) if isinstance(stream, bytes) else stream
    data = np.ascontiguousarray(data, dtype=np.uint8)
    lits = np.empty(max(0, max_inflated), dtype=np.uint8)
    for capacity in (8 * len(data) + 64, max(0, max_inflated) + 2):
        # at most one symbol per bit, except for copies split at their sources' symbols;
        # and never more symbols than bytes
        starts = np.empty(capacity + 1, dtype=np.int64)
        infos = np.empty(capacity, dtype=np.int64)
        n, n_lits = _decode_stream(data, starts, infos, lits)
        if n != -8:
            break
    if n < 0:
        raise InflateError(FAILURES.get(-int(n), "invalid stream"))
    return Symbols(starts[: n + 1].copy(), infos[:n].copy(), lits[:n_lits].copy())


def pick(symbols: Symbols, wanted: NDArray[np.int64]) -> NDArray[np.uint8]:
    """Return the inflated bytes at positions ``wanted`` (any order; ascending is fastest).

    Raises
    ------
    InflateError
        A position lies outside ``0 .. size - 1``.
    """
    wanted = np.ascontiguousarray(wanted, dtype=np.int64)
    out = np.empty(len(wanted), dtype=np.uint8)
    if not _pick(symbols.starts, symbols.infos, symbols.lits, wanted, out):
        raise InflateError(f"{FAILURES[6]} ({symbols.size} bytes)")
    return out


def pick_bytes(
    data: NDArray[np.uint8],
    stream_bounds: NDArray[np.int64],
    wanted: NDArray[np.int64],
    wanted_bounds: NDArray[np.int64],
    *,
    max_inflated: int,
) -> NDArray[np.uint8]:
    """Return chosen bytes of many zlib streams (:func:`decode`, then :func:`pick`).

    Parameters
    ----------
    data : (B,) uint8
        The zlib streams back to back.
    stream_bounds : (S + 1,) int64
        Stream ``s`` is ``data[stream_bounds[s]:stream_bounds[s + 1]]``.
    wanted : (N,) int64
        Byte positions in the inflated streams.
    wanted_bounds : (S + 1,) int64
        The positions of stream ``s`` are ``wanted[wanted_bounds[s]:wanted_bounds[s + 1]]``.
    max_inflated : int
        Bytes a stream may inflate to; more is an error.

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
    >>> bounds = np.array([0, len(packed)])
    >>> wanted = np.array([0, 7, 9999])
    >>> pick_bytes(packed, bounds, wanted, np.array([0, 3]), max_inflated=len(raw)).tolist()
    [0, 7, 199]
    """
    data = np.ascontiguousarray(data, dtype=np.uint8)
    stream_bounds = np.asarray(stream_bounds, dtype=np.int64)
    wanted = np.asarray(wanted, dtype=np.int64)
    wanted_bounds = np.asarray(wanted_bounds, dtype=np.int64)
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
    out = np.empty(len(wanted), dtype=np.uint8)
    for s in range(len(stream_bounds) - 1):
        w0, w1 = wanted_bounds[s], wanted_bounds[s + 1]
        if w0 == w1:
            continue
        try:
            symbols = decode(data[stream_bounds[s] : stream_bounds[s + 1]],
                             max_inflated=max_inflated)  # fmt: skip
            out[w0:w1] = pick(symbols, wanted[w0:w1])
        except InflateError as error:
            raise InflateError(f"stream {s}: {error}") from None
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _pick(
    starts: NDArray[np.int64],
    infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
    wanted: NDArray[np.int64],
    out: NDArray[np.uint8],
) -> bool:
    """Fill ``out`` with the bytes at ``wanted``; False if one lies outside the stream."""
    n = len(infos)
    total = starts[n]
    m = 0
    for i in range(len(wanted)):
        p = wanted[i]
        if p < 0 or p >= total:
            return False
        if p < starts[m]:  # not ascending: search again
            m = _find(p, m + 1, starts)
        while starts[m + 1] <= p:
            m += 1
        out[i] = _value(p, m, starts, infos, lits)
    return True


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _find(p: int, hi: int, starts: NDArray[np.int64]) -> int:
    """Return the last symbol ``m < hi`` with ``starts[m] <= p``."""
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
    p: int, m: int, starts: NDArray[np.int64], infos: NDArray[np.int64], lits: NDArray[np.uint8]
) -> int:
    """Return the inflated byte at ``p``, held by symbol ``m``."""
    offset = p - starts[m]
    info = infos[m]
    if info >= 0:
        return int(lits[info + offset])
    x = -info - 1
    return int((x >> (8 * (1 + offset % (x & 0xFF)))) & 0xFF)


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _rotate(pattern: int, period: int, phase: int) -> int:
    """Return a pattern of ``period`` bytes started at byte ``phase`` instead of 0."""
    out = 0
    for j in range(period):
        out |= ((pattern >> (8 * ((phase + j) % period))) & 0xFF) << (8 * j)
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _continues(
    n: int, total: int, period: int, pattern: int, starts: NDArray[np.int64],
    infos: NDArray[np.int64],
) -> bool:  # fmt: skip
    """Whether a run of ``pattern`` (period ``period``) at ``total`` goes on symbol ``n - 1``."""
    if n == 0 or infos[n - 1] >= 0:
        return False
    x = -infos[n - 1] - 1
    if (x & 0xFF) != period:
        return False
    return _rotate(x >> 8, period, (total - starts[n - 1]) % period) == pattern


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
def _put(
    source: NDArray[np.uint8], count: int, n: int, n_lits: int, total: int, tail: int,
    starts: NDArray[np.int64], infos: NDArray[np.int64], lits: NDArray[np.uint8],
) -> tuple[int, int, int, int]:  # fmt: skip
    """Append inflated bytes ``source[:count]``; return ``(n, n_lits, total, tail)``.

    Bytes go to the literals, except that a run of ``_SHORT_RUN`` equal bytes becomes a
    run symbol (period 1) that the following equal bytes extend: zlib copies runs in
    pieces, and a run kept as literals would be copied on as literals. ``tail`` counts
    the equal bytes ending the literals. ``n`` is -1 when ``infos`` has no room.
    (One call for many bytes: a call per byte costs more than the work.)
    """
    for k in range(count):
        byte = int(source[k])
        if n > 0 and infos[n - 1] < 0:
            if -infos[n - 1] - 1 == (1 | (byte << 8)):  # the run of this byte goes on
                total += 1
                starts[n] = total
                continue
            if n >= len(infos):
                return -1, n_lits, total, 0
            infos[n] = n_lits
            n += 1
            tail = 0
        elif n == 0:
            infos[0] = n_lits
            n = 1
            tail = 0
        tail = tail + 1 if tail > 0 and lits[n_lits - 1] == byte else 1
        lits[n_lits] = byte
        n_lits += 1
        total += 1
        starts[n] = total
        if tail == _SHORT_RUN:  # the last bytes are a run: a run symbol from its first
            n_lits -= tail
            if total - tail == starts[n - 1]:
                infos[n - 1] = -(1 | (byte << 8)) - 1
            else:
                if n >= len(infos):
                    return -1, n_lits, total, 0
                starts[n] = total - tail
                infos[n] = -(1 | (byte << 8)) - 1
                n += 1
                starts[n] = total
            tail = 0
    return n, n_lits, total, tail


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _decode_stream(
    data: NDArray[np.uint8], starts: NDArray[np.int64], infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
) -> tuple[int, int]:  # fmt: skip
    """Decode one zlib stream into symbols; return ``(n_symbols, n_lits)``.

    ``n_symbols`` is minus a failure code (:data:`FAILURES`) when the stream is invalid
    (-8: more symbols than ``infos`` holds). ``starts[n]`` is kept at the inflated size.
    """
    stop = len(data)
    if stop < 2:
        return -2, 0
    cmf = int(data[0])
    flg = int(data[1])
    if (cmf & 0x0F) != 8 or (cmf * 256 + flg) % 31 != 0 or (flg & 0x20) != 0:
        return -1, 0
    capacity = len(infos)
    st = np.zeros(4, dtype=np.int64)  # byte position, stop, bit buffer, bits in it
    st[0] = 2
    st[1] = stop
    lcount = np.zeros(16, dtype=np.int64)
    lsymbol = np.zeros(288, dtype=np.int64)
    dcount = np.zeros(16, dtype=np.int64)
    dsymbol = np.zeros(30, dtype=np.int64)
    ltable = np.zeros(1 << _TABLE_BITS, dtype=np.int64)
    dtable = np.zeros(1 << _TABLE_BITS, dtype=np.int64)
    piece = np.zeros(258, dtype=np.uint8)  # the bytes of a copy, read before written
    fixed = _fixed_lengths()
    mask = (1 << _TABLE_BITS) - 1
    n = 0  # symbols
    n_lits = 0
    total = 0  # inflated bytes so far
    tail = 0  # equal bytes ending the literals (see _put)
    starts[0] = 0
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
            n, n_lits, total, tail = _put(
                data[st[0] : st[0] + size], size, n, n_lits, total, tail, starts, infos, lits
            )
            if n < 0:
                return -8, 0
            st[0] += size
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
            if sym < 256:  # a literal (as in _put, written out: this is the hot path)
                if total >= len(lits):
                    return -7, 0
                if n == 0 or infos[n - 1] < 0 or tail + 1 >= _SHORT_RUN:
                    piece[0] = sym
                    n, n_lits, total, tail = _put(
                        piece, 1, n, n_lits, total, tail, starts, infos, lits
                    )
                    if n < 0:
                        return -8, 0
                    continue
                tail = tail + 1 if tail > 0 and lits[n_lits - 1] == sym else 1
                lits[n_lits] = sym
                n_lits += 1
                total += 1
                starts[n] = total
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
                # a run repeating the last `distance` bytes
                if n > 0 and infos[n - 1] < 0:
                    x = -infos[n - 1] - 1
                    if distance % (x & 0xFF) == 0 and total - starts[n - 1] >= distance:
                        total += length  # the same periodic run goes on
                        starts[n] = total
                        continue
                pattern = 0
                m = n - 1
                for j in range(distance):
                    p = total - distance + j
                    while starts[m] > p:
                        m -= 1
                    pattern |= _value(p, m, starts, infos, lits) << (8 * j)
                    m = n - 1
                if length < _SHORT_RUN and distance == 1 and infos[n - 1] >= 0:
                    # a short run after literals: more literals (the common case, fast)
                    run = tail + length if lits[n_lits - 1] == pattern else length
                    if run < _SHORT_RUN:
                        lits[n_lits : n_lits + length] = pattern
                        n_lits += length
                        total += length
                        starts[n] = total
                        tail = run
                        continue
                if length < _SHORT_RUN:  # cheaper as literals
                    for k in range(length):
                        piece[k] = (pattern >> (8 * (k % distance))) & 0xFF
                    n, n_lits, total, tail = _put(
                        piece, length, n, n_lits, total, tail, starts, infos, lits
                    )
                    if n < 0:
                        return -8, 0
                    continue
                if infos[n - 1] >= 0 and total - starts[n - 1] >= distance:
                    # the literals it repeats start the run: a run starts where its bytes do
                    # (copies of it then meet one symbol, not a literal and a run)
                    n_lits -= distance
                    if total - starts[n - 1] == distance:
                        n -= 1
                    else:
                        starts[n] = total - distance
                if n >= capacity:
                    return -8, 0
                infos[n] = -(distance | (pattern << 8)) - 1
                n += 1
                total += length
                starts[n] = total
                tail = 0
                continue
            # a copy from further back: copies of the symbols it spans
            q = total - distance
            k = 0
            while k < length:
                m = _find(q, n, starts)
                chunk = min(starts[m + 1] - q, length - k)
                info = infos[m]
                if info < 0 and chunk >= _SHORT_RUN:  # a piece of a run
                    x = -info - 1
                    period = x & 0xFF
                    pattern = _rotate(x >> 8, period, (q - starts[m]) % period)
                    if not _continues(n, total, period, pattern, starts, infos):
                        if n >= capacity:
                            return -8, 0
                        infos[n] = -(period | (pattern << 8)) - 1
                        n += 1
                        tail = 0
                    total += chunk
                    starts[n] = total
                else:  # literal bytes (or a short piece of a run): read, then appended
                    if info >= 0:
                        source = info + q - starts[m]
                        piece[:chunk] = lits[source : source + chunk]
                    else:
                        for j in range(chunk):
                            piece[j] = _value(q + j, m, starts, infos, lits)
                    n, n_lits, total, tail = _put(
                        piece, chunk, n, n_lits, total, tail, starts, infos, lits
                    )
                    if n < 0:
                        return -8, 0
                q += chunk
                k += chunk
        # give back the whole bytes read ahead: the bit reader continues at the byte
        st[0] = pos - held // 8
        st[2] = buf & ((1 << (held % 8)) - 1)
        st[3] = held % 8
    if final < 0:
        return -2, 0
    return n, n_lits
