"""Random access into zlib streams: chosen bytes of a stream without inflating all of it.

A voxel slice along y or x needs one row or one column of every TIFF page, and a page is
a deflate stream (RFC 1951), which has no random access: zlib writes out every byte
before the ones asked for (0.4 GB/s on voxel pages). :func:`decode` reads a stream's
*symbols* instead and writes no output: a run of literals is kept as its bytes, a match
at a distance of 1 to 4 bytes (the runs of a voxel page) as its repeating pattern of 1
to 4 bytes, and a match from further back (the pages are zlib-ng's or zlib's streams,
:mod:`voxel.io._compression`, whose matches may reach anywhere in the window) as copies
of the symbols it repeats. The result, :class:`Symbols`, is a run-length description of
the inflated bytes, about as large as the compressed stream; :func:`pick` reads any
bytes of it by binary search. Decoding costs per symbol, not per byte: a page of long
runs decodes several times faster than zlib inflates it, and a decoded page answers any
row or column at once.

The compiled parts: Huffman codes in :mod:`pipeline.viewer._huffman` (after Mark Adler's
``puff.c``, the reference inflater in zlib's ``contrib/puff``), the block walk that
writes the symbols in :mod:`pipeline.viewer._symbol_stream`.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from pipeline.viewer._symbol_stream import decode_stream, find_run, run_value

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
        n, n_lits = decode_stream(data, starts, infos, lits)
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
            symbols = decode(
                data[stream_bounds[s] : stream_bounds[s + 1]], max_inflated=max_inflated
            )
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
            m = find_run(p, m + 1, starts)
        while starts[m + 1] <= p:
            m += 1
        out[i] = run_value(p, m, starts, infos, lits)
    return True
