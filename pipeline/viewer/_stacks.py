"""Lazy reads of a build's TIFF stacks: any region of a slice along z, y or x.

A stack (``layers.tif``, ``colour.tif``, ``materials.tif``) is ``Z`` deflate-compressed
pages of ``(Y, X[, S])`` uint8, each page one strip or a few (what
:mod:`shellvox.voxel.io._tiff_writer` writes). The page and strip offsets are read once (tifffile);
the file stays open and every read is an ``os.pread`` of the strips a region needs, so
any number of server threads read at once. A z slice inflates its strips with zlib; a
y or x slice takes one row or column of every page it covers, inflating each of those
pages whole (a strip of deflate can only be read from its start). Inflated strips are
kept in a :class:`StripCache` shared by the stacks of a build, so the next y or x slice
through the same pages only reads them; a build large enough for that to be slow has
its OME-Zarr store (:mod:`shellvox.viewer._zarr_stacks`), which answers any axis from
chunks. Regions are ``range`` objects of indices with a step: a view zoomed out to a
whole 5 G-voxel model asks for every fourth page, not all of them.
"""

from __future__ import annotations

import os
import struct
import threading
import zlib
from collections import OrderedDict
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Literal

import numpy as np
import tifffile
from numpy.typing import NDArray

Axis = Literal["z", "y", "x"]

#: TIFF compression codes read: deflate (the TIFF 6 code and Adobe's).
DEFLATE = (8, 32946)
#: What tifffile raises on a file that is not a whole TIFF (struct.error: an IFD cut short).
_UNREADABLE = (OSError, tifffile.TiffFileError, ValueError, IndexError, KeyError, struct.error)

#: Strips below which a slice is read in one thread (above: two; zlib releases the GIL).
_SPLIT_STREAMS = 64

#: Memory for inflated strips kept between requests, bytes.
CACHE_BYTES = 1 << 30


class StripCache:
    """Inflated strips, least recently used first out, within a memory budget.

    Parameters
    ----------
    budget_bytes : int
        Memory the kept strips (uint8 arrays) may hold.
    """

    def __init__(self, budget_bytes: int = CACHE_BYTES) -> None:
        self.budget_bytes = budget_bytes
        self.used_bytes = 0
        self._items: OrderedDict[tuple[int, int, int], NDArray[np.uint8]] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: tuple[int, int, int]) -> NDArray[np.uint8] | None:
        """Return the strip at ``(stack id, page, strip)``, or None."""
        with self._lock:
            strip = self._items.get(key)
            if strip is not None:
                self._items.move_to_end(key)
            return strip

    def put(self, key: tuple[int, int, int], strip: NDArray[np.uint8]) -> None:
        """Keep an inflated strip, dropping the least recently used beyond the budget."""
        with self._lock:
            if key in self._items:
                return
            self._items[key] = strip
            self.used_bytes += strip.nbytes
            while self.used_bytes > self.budget_bytes and self._items:
                _, dropped = self._items.popitem(last=False)
                self.used_bytes -= dropped.nbytes


#: The axes of a section's rows and columns, for each axis it is cut across.
PLANE: dict[str, tuple[Axis, Axis]] = {"z": ("y", "x"), "y": ("z", "x"), "x": ("z", "y")}


def region_shape(
    shape_zyx: Sequence[int], samples: int, axis: Axis, index: int, rows: range, cols: range
) -> tuple[int, ...]:
    """Return the shape of a region of a section; raise IndexError when it leaves the stack.

    ``(len(rows), len(cols))``, with ``samples`` last when it is not 0.
    """
    extent = dict(zip("zyx", shape_zyx, strict=True))
    row_axis, col_axis = PLANE[axis]
    if not 0 <= index < extent[axis]:
        raise IndexError(f"{axis} index {index} is outside 0..{extent[axis] - 1}")
    for name, r, along in (("rows", rows, row_axis), ("cols", cols, col_axis)):
        if r.step < 1 or (len(r) and not (r[0] >= 0 and r[-1] < extent[along])):
            raise IndexError(f"{name} {r} must lie in 0..{extent[along] - 1}, step >= 1")
    return (len(rows), len(cols), samples) if samples else (len(rows), len(cols))


class StackError(ValueError):
    """A TIFF stack cannot be read as a build's stack (shape, type, layout, damage)."""


class TiffStack:
    """One ``(Z, Y, X[, S])`` uint8 stack, open for region reads from many threads.

    Parameters
    ----------
    path : Path
        The TIFF file.
    shape_zyx : (3,) int
        The build's grid ``(Z, Y, X)``; the file must hold exactly this.
    samples : int
        0 for a grey stack, 3 or 4 for RGB(A).
    cache : StripCache, optional
        Where inflated strips are kept (shared by a build's stacks); default: a new one.

    Raises
    ------
    StackError
        The file is not such a stack: wrong size or type, predictor, tiles, compression
        other than deflate, or offsets past its end.
    """

    def __init__(
        self,
        path: Path,
        shape_zyx: Sequence[int],
        *,
        samples: int,
        cache: StripCache | None = None,
    ) -> None:
        self.path = Path(path)
        self.cache = cache if cache is not None else StripCache()
        self.shape_zyx = (int(shape_zyx[0]), int(shape_zyx[1]), int(shape_zyx[2]))
        self.samples = samples
        self._pool: ThreadPoolExecutor | None = None
        self._pool_lock = threading.Lock()
        self.offsets, self.counts, self.rows_per_strip = _strip_index(
            self.path, self.shape_zyx, samples
        )
        self._fd = os.open(self.path, os.O_RDONLY)

    @property
    def pixel_bytes(self) -> int:
        """Bytes per voxel (1, 3 or 4)."""
        return max(1, self.samples)

    def close(self) -> None:
        """Close the file (reads afterwards fail)."""
        if self._pool is not None:
            self._pool.shutdown()
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> TiffStack:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def region(self, axis: Axis, index: int, rows: range, cols: range) -> NDArray[np.uint8]:
        """Return a region of the slice at ``index`` along ``axis``.

        Parameters
        ----------
        axis : {"z", "y", "x"}
            The slice's normal. Its rows and columns are ``(y, x)`` for z, ``(z, x)``
            for y and ``(z, y)`` for x, in index order (row 0 the lowest index).
        index : int
            Position of the slice along ``axis``.
        rows, cols : range
            Indices (with a positive step) of the rows and columns to read.

        Returns
        -------
        (len(rows), len(cols)[, S]) uint8
        """
        shape = region_shape(self.shape_zyx, self.samples, axis, index, rows, cols)
        if not len(rows) or not len(cols):
            return np.zeros(shape, dtype=np.uint8)
        if axis == "z":
            return self._page_region(index, rows, cols).reshape(shape)
        pages = np.asarray(rows, dtype=np.int64)
        if axis == "y":
            ys = np.array([index], dtype=np.int64)
            xs = np.asarray(cols, dtype=np.int64)
        else:
            ys = np.asarray(cols, dtype=np.int64)
            xs = np.array([index], dtype=np.int64)
        return self._across_pages(pages, ys, xs).reshape(shape)

    #: Pages :meth:`pages` reads at a time to no advantage (a page decodes alone).
    page_block = 1

    #: Rows of a strip of pages that costs no more to read than its share of whole pages.
    row_block = 1

    def pages(self, z0: int, z1: int, y0: int = 0, y1: int | None = None) -> NDArray[np.uint8]:
        """Return rows ``y0 <= y < y1`` (default: all) of the pages ``z0 <= z < z1``.

        Returns
        -------
        (z1 - z0, y1 - y0, X[, S]) uint8
        """
        rows = range(y0, self.shape_zyx[1] if y1 is None else y1)
        cols = range(self.shape_zyx[2])
        return np.stack([self.region("z", z, rows, cols) for z in range(z0, z1)])

    def voxel(self, z: int, y: int, x: int) -> NDArray[np.uint8]:
        """Return voxel ``(z, y, x)``: ``(S,)`` uint8 (``(1,)`` for a grey stack)."""
        value = self.region("y", y, range(z, z + 1), range(x, x + 1))
        return value.reshape(-1)

    def _page_region(self, z: int, rows: range, cols: range) -> NDArray[np.uint8]:
        """Inflate the strips of page ``z`` that hold ``rows``; return the region."""
        n_x = self.shape_zyx[2]
        rps = self.rows_per_strip
        first, last = rows[0] // rps, rows[-1] // rps
        parts = [self._inflate(z, s) for s in range(first, last + 1)]
        block = np.frombuffer(b"".join(parts), dtype=np.uint8)
        block = block.reshape(-1, n_x, self.pixel_bytes)
        row_slice = slice(rows.start - first * rps, rows[-1] - first * rps + 1, rows.step)
        col_slice = slice(cols.start, cols[-1] + 1, cols.step)
        return np.ascontiguousarray(block[row_slice, col_slice])

    def _inflate(self, z: int, strip: int) -> bytes:
        """Return a strip's bytes, inflating no more than one byte past what it must hold."""
        raw = os.pread(self._fd, int(self.counts[z, strip]), int(self.offsets[z, strip]))
        expected = self._strip_rows(strip) * self.shape_zyx[2] * self.pixel_bytes
        inflater = zlib.decompressobj()
        try:
            data = inflater.decompress(raw, expected + 1)
        except zlib.error as error:
            raise StackError(f"{self.path}: page {z} cannot be inflated ({error})") from None
        if len(data) == expected and inflater.eof:
            return data
        if len(data) > expected:
            held = f"more than {expected} bytes"
        elif len(data) < expected:
            held = f"{len(data)} bytes"
        else:
            held = f"{expected} bytes of a stream cut short"
        raise StackError(f"{self.path}: page {z} holds {held}, not {expected}")

    def _strip_rows(self, strip: int) -> int:
        return min(self.rows_per_strip, self.shape_zyx[1] - strip * self.rows_per_strip)

    def _across_pages(
        self, pages: NDArray[np.int64], ys: NDArray[np.int64], xs: NDArray[np.int64]
    ) -> NDArray[np.uint8]:
        """Voxels ``(pages, ys, xs)`` (an outer product) read from each page's strips."""
        n_x = self.shape_zyx[2]
        size = self.pixel_bytes
        rps = self.rows_per_strip
        # byte positions inside each strip used, in (y, x, sample) order
        positions = []
        for strip in np.unique(ys // rps):
            local = ys[ys // rps == strip] - strip * rps
            pos = ((local[:, None] * n_x + xs[None, :]) * size)[..., None] + np.arange(size)
            positions.append((int(strip), pos.reshape(-1)))
        jobs = [(int(z), strip, pos) for z in pages for strip, pos in positions]
        if len(jobs) < 2 * _SPLIT_STREAMS:
            parts = self._read(jobs)
        else:  # two halves at once (zlib releases the GIL)
            half = len(jobs) // 2
            second = self._executor().submit(self._read, jobs[half:])
            parts = self._read(jobs[:half]) + second.result()
        return np.concatenate(parts).reshape(len(pages), len(ys), len(xs), size)

    def _read(self, jobs: list[tuple[int, int, NDArray[np.int64]]]) -> list[NDArray[np.uint8]]:
        """Bytes at positions in strips: ``[(page, strip, positions), ...]``."""
        out = []
        for z, strip, positions in jobs:
            key = (id(self), z, strip)
            data = self.cache.get(key)
            if data is None:
                data = np.frombuffer(self._inflate(z, strip), dtype=np.uint8)
                self.cache.put(key, data)
            out.append(data[positions])
        return out

    def warm(self, pages: range, stop: threading.Event) -> None:
        """Inflate every strip of ``pages`` into the cache (until ``stop`` is set).

        Run in a background thread, so that y and x slices through these pages are read
        from the cache.
        """
        n_strips = self.offsets.shape[1]
        for z in pages:
            for strip in range(n_strips):
                if stop.is_set() or self._fd < 0:
                    return
                if self.cache.used_bytes > 0.8 * self.cache.budget_bytes:
                    return
                self._read([(z, strip, np.zeros(1, dtype=np.int64))])

    def _executor(self) -> ThreadPoolExecutor:
        with self._pool_lock:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix=f"{self.path.name}")
            return self._pool


def _strip_index(
    path: Path, shape_zyx: tuple[int, int, int], samples: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """Read and check the strip offsets and byte counts of every page.

    Returns
    -------
    offsets, counts : (Z, strips) int64
    rows_per_strip : int
    """
    n_z, n_y, n_x = shape_zyx
    page_shape = (n_y, n_x, samples) if samples else (n_y, n_x)
    try:
        with tifffile.TiffFile(path) as tif:
            first = tif.pages.first
            problems = []
            if first.shape != page_shape or first.dtype != np.uint8:
                problems.append(f"pages of {first.dtype} {first.shape}, not uint8 {page_shape}")
            if first.is_tiled:
                problems.append("tiled pages")
            if int(first.compression) not in DEFLATE:
                problems.append(f"compression {int(first.compression)}, not deflate")
            if int(first.predictor) != 1:
                problems.append(f"predictor {int(first.predictor)}")
            if samples and int(first.planarconfig) != 1:
                problems.append("separate colour planes")
            if problems:
                raise StackError(f"{path}: {'; '.join(problems)}")
            tif.pages.useframes = True
            tif.pages.cache = False
            offsets, counts = [], []
            for page in tif.pages:
                offsets.append(page.dataoffsets)
                counts.append(page.databytecounts)
            rows_per_strip = int(first.rowsperstrip) or n_y
    except _UNREADABLE as error:
        if isinstance(error, StackError):
            raise
        raise StackError(f"{path}: not a readable TIFF stack ({error})") from None
    n_strips = -(-n_y // min(rows_per_strip, n_y))
    if len(offsets) != n_z or any(len(o) != n_strips for o in offsets):
        raise StackError(
            f"{path}: {len(offsets)} pages of {sorted({len(o) for o in offsets})} strips, "
            f"not {n_z} of {n_strips}"
        )
    offset_array = np.asarray(offsets, dtype=np.int64).reshape(n_z, n_strips)
    count_array = np.asarray(counts, dtype=np.int64).reshape(n_z, n_strips)
    size = path.stat().st_size
    if np.any(offset_array + count_array > size) or np.any(count_array < 2):
        raise StackError(f"{path}: strips reach past the end of the file (truncated?)")
    return offset_array, count_array, min(rows_per_strip, n_y)
