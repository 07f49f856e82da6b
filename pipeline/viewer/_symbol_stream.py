"""The symbol decoder behind :mod:`pipeline.viewer._inflate`: deflate blocks to runs, compiled.

:func:`decode_stream` walks a zlib stream's blocks (stored, fixed and dynamic Huffman,
:mod:`pipeline.viewer._huffman`) and writes its symbols (literal bytes, short-period
runs, copies) into run tables instead of inflating them; :func:`find_run`,
:func:`run_value` and their helpers read a byte of such a table.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from pipeline.viewer._huffman import (
    TABLE_BITS,
    bits,
    construct,
    dynamic_tables,
    fixed_lengths,
    long_code,
    table,
)

#: Base length and extra bits of length symbols 257..285 (RFC 1951 section 3.2.5).
LEN_BASE = np.array(
    [3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99,
     115, 131, 163, 195, 227, 258], dtype=np.int64)  # fmt: skip
LEN_EXTRA = np.array(
    [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0],
    dtype=np.int64)  # fmt: skip
DIST_BASE = np.array(
    [1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025,
     1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577], dtype=np.int64)  # fmt: skip
DIST_EXTRA = np.array(
    [0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12,
     12, 13, 13], dtype=np.int64)  # fmt: skip
#: Runs shorter than this are kept as literal bytes (a run symbol takes 16 bytes).
SHORT_RUN = 16


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def find_run(p: int, hi: int, starts: NDArray[np.int64]) -> int:
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
def run_value(
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
def rotate(pattern: int, period: int, phase: int) -> int:
    """Return a pattern of ``period`` bytes started at byte ``phase`` instead of 0."""
    out = 0
    for j in range(period):
        out |= ((pattern >> (8 * ((phase + j) % period))) & 0xFF) << (8 * j)
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def continues(
    n: int,
    total: int,
    period: int,
    pattern: int,
    starts: NDArray[np.int64],
    infos: NDArray[np.int64],
) -> bool:
    """Whether a run of ``pattern`` (period ``period``) at ``total`` goes on symbol ``n - 1``."""
    if n == 0 or infos[n - 1] >= 0:
        return False
    x = -infos[n - 1] - 1
    if (x & 0xFF) != period:
        return False
    return rotate(x >> 8, period, (total - starts[n - 1]) % period) == pattern


@numba.njit(cache=True, nogil=True, error_model="numpy")
def put(
    source: NDArray[np.uint8],
    count: int,
    n: int,
    n_lits: int,
    total: int,
    tail: int,
    starts: NDArray[np.int64],
    infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
) -> tuple[int, int, int, int]:
    """Append inflated bytes ``source[:count]``; return ``(n, n_lits, total, tail)``.

    Bytes go to the literals, except that a run of ``SHORT_RUN`` equal bytes becomes a
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
        if tail == SHORT_RUN:  # the last bytes are a run: a run symbol from its first
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
def decode_stream(
    data: NDArray[np.uint8],
    starts: NDArray[np.int64],
    infos: NDArray[np.int64],
    lits: NDArray[np.uint8],
) -> tuple[int, int]:
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
    ltable = np.zeros(1 << TABLE_BITS, dtype=np.int64)
    dtable = np.zeros(1 << TABLE_BITS, dtype=np.int64)
    piece = np.zeros(258, dtype=np.uint8)  # the bytes of a copy, read before written
    fixed = fixed_lengths()
    mask = (1 << TABLE_BITS) - 1
    n = 0  # symbols
    n_lits = 0
    total = 0  # inflated bytes so far
    tail = 0  # equal bytes ending the literals (see put)
    starts[0] = 0
    final = 0
    while final == 0:
        final = bits(data, st, 1)
        kind = bits(data, st, 2)
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
            n, n_lits, total, tail = put(
                data[st[0] : st[0] + size], size, n, n_lits, total, tail, starts, infos, lits
            )
            if n < 0:
                return -8, 0
            st[0] += size
            continue
        if kind == 1:
            construct(fixed, 288, lcount, lsymbol)
            construct(fixed[288:], 30, dcount, dsymbol)
            table(fixed, 288, lcount, ltable)
            table(fixed[288:], 30, dcount, dtable)
        elif kind == 2:
            err = dynamic_tables(data, st, lcount, lsymbol, dcount, dsymbol, ltable, dtable)
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
                entry = long_code(buf, lcount, lsymbol)
            used = entry & 15
            if used == 0:
                return -4, 0
            if used > held:
                return -2, 0
            buf >>= used
            held -= used
            sym = entry >> 4
            if sym < 256:  # a literal (as in put, written out: this is the hot path)
                if total >= len(lits):
                    return -7, 0
                if n == 0 or infos[n - 1] < 0 or tail + 1 >= SHORT_RUN:
                    piece[0] = sym
                    n, n_lits, total, tail = put(
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
            used = LEN_EXTRA[sym]
            if used > held:
                return -2, 0
            length = LEN_BASE[sym] + (buf & ((1 << used) - 1))
            buf >>= used
            held -= used
            entry = dtable[buf & mask]
            if entry == 0:
                entry = long_code(buf, dcount, dsymbol)
            used = entry & 15
            if used == 0 or (entry >> 4) >= 30:
                return -4, 0
            if used > held:
                return -2, 0
            buf >>= used
            held -= used
            dsym = entry >> 4
            used = DIST_EXTRA[dsym]
            if used > held:
                return -2, 0
            distance = DIST_BASE[dsym] + (buf & ((1 << used) - 1))
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
                    pattern |= run_value(p, m, starts, infos, lits) << (8 * j)
                    m = n - 1
                if length < SHORT_RUN and distance == 1 and infos[n - 1] >= 0:
                    # a short run after literals: more literals (the common case, fast)
                    run = tail + length if lits[n_lits - 1] == pattern else length
                    if run < SHORT_RUN:
                        lits[n_lits : n_lits + length] = pattern
                        n_lits += length
                        total += length
                        starts[n] = total
                        tail = run
                        continue
                if length < SHORT_RUN:  # cheaper as literals
                    for k in range(length):
                        piece[k] = (pattern >> (8 * (k % distance))) & 0xFF
                    n, n_lits, total, tail = put(
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
                m = find_run(q, n, starts)
                chunk = min(starts[m + 1] - q, length - k)
                info = infos[m]
                if info < 0 and chunk >= SHORT_RUN:  # a piece of a run
                    x = -info - 1
                    period = x & 0xFF
                    pattern = rotate(x >> 8, period, (q - starts[m]) % period)
                    if not continues(n, total, period, pattern, starts, infos):
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
                            piece[j] = run_value(q + j, m, starts, infos, lits)
                    n, n_lits, total, tail = put(
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
