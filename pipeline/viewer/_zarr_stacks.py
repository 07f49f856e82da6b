"""Slice regions read from a build's OME-Zarr store (``stack.ome.zarr``), any axis.

An image of the store (the colour image at its root, ``labels/layers``,
``labels/materials``) is a pyramid of chunked arrays (what
:mod:`voxel.io._zarr_writer` writes), read here with ``zarr``. A region asks for every
``step``-th voxel of its rows and columns: it is read from the coarsest level whose voxels
are no larger than that along the rows and the columns, and no larger than the larger step
along the slice's normal (a zoomed-out view of a 5 G-voxel build reads a level of a few
hundred megavoxels); at one voxel per pixel it reads level 0. The level's voxel holding
each asked-for voxel gives its value (the mode of the labels, the colour layers' mean
colour there).

What a slice reads is a band: across the slice, the whole chunks holding the region;
along its normal, the chunks holding the slice when that band is small (up to 1/32 of the
budget), else the :data:`THIN_PLANES` planes around it (aligned to that many; fewer while
the band would be larger than that). zarr decodes each chunk the band crosses once either
way, so a thin band costs little more than the slice alone (assembling a few hundred
megabytes of whole chunks costs several times more than decoding them). Bands are kept in
a :class:`BlockCache` shared by the images of a build (least recently used first out), so
the next slices through them (a slice's neighbours, the same region panned a little less
than a chunk) are picked from memory.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray

from pipeline.viewer._stacks import PLANE, Axis, StackError, region_shape

#: Memory for the bands kept between requests, bytes.
CACHE_BYTES = 1 << 30
#: A band is at most the budget over this (unless the slice's steps do not fit the
#: level's voxels, which the page never asks for: then its whole chunks are read).
BAND_SHARE = 32
#: Planes along the normal of a thin band, the aligned group holding the slice (a power
#: of two).
THIN_PLANES = 8

#: The axes of a slice's rows and columns (and their positions in ``(z, y, x)``).
_POSITION = {"z": 0, "y": 1, "x": 2}

#: A band: (image id, level, axis, box (start, stop) along z, y and x).
BandKey = tuple[int, int, str, tuple[tuple[int, int], ...]]


class BlockCache:
    """Decoded bands of chunks, least recently used first out, within a memory budget.

    Parameters
    ----------
    budget_bytes : int
        Memory the kept arrays may hold.
    """

    def __init__(self, budget_bytes: int = CACHE_BYTES) -> None:
        self.budget_bytes = budget_bytes
        self.used_bytes = 0
        self._items: OrderedDict[BandKey, NDArray[np.uint8]] = OrderedDict()
        self._lock = threading.Lock()

    def find(self, key: BandKey) -> tuple[BandKey, NDArray[np.uint8]] | None:
        """Return a kept band of the same image, level and axis whose box holds `key`'s."""
        image, level, axis, box = key
        with self._lock:
            for kept, array in reversed(self._items.items()):
                if kept[:3] == (image, level, axis) and all(
                    a0 <= b0 and b1 <= a1 for (a0, a1), (b0, b1) in zip(kept[3], box, strict=True)
                ):
                    self._items.move_to_end(kept)
                    return kept, array
        return None

    def put(self, key: BandKey, array: NDArray[np.uint8]) -> None:
        """Keep a band, dropping the least recently used beyond the budget."""
        with self._lock:
            if key in self._items:
                return
            self._items[key] = array
            self.used_bytes += array.nbytes
            while self.used_bytes > self.budget_bytes and len(self._items) > 1:
                _, dropped = self._items.popitem(last=False)
                self.used_bytes -= dropped.nbytes


class ZarrStack:
    """One image of the store, ``(Z, Y, X[, S])`` uint8 at level 0, open for region reads.

    Parameters
    ----------
    path : Path
        The image's group (the store's root for colour, ``labels/NAME`` for labels).
    shape_zyx : (3,) int
        The build's grid ``(Z, Y, X)``; level 0 must hold exactly this.
    samples : int
        0 for a label image, 3 or 4 for the colour image ``(S, Z, Y, X)``.
    cache : BlockCache, optional
        Where read bands are kept (shared by a build's images); default: a new one.

    Raises
    ------
    StackError
        The group is not such an image (metadata, shapes, type).
    """

    def __init__(
        self,
        path: Path,
        shape_zyx: Sequence[int],
        *,
        samples: int,
        cache: BlockCache | None = None,
    ) -> None:
        self.path = Path(path)
        self.shape_zyx = (int(shape_zyx[0]), int(shape_zyx[1]), int(shape_zyx[2]))
        self.samples = samples
        self.cache = cache if cache is not None else BlockCache()
        self.levels, self.factors = _open_levels(self.path, self.shape_zyx, samples)

    @property
    def pixel_bytes(self) -> int:
        """Bytes per voxel (1, 3 or 4)."""
        return max(1, self.samples)

    def close(self) -> None:
        """Nothing stays open between reads (the store's files are opened per read)."""

    def __enter__(self) -> ZarrStack:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def warm(self, pages: range, stop: threading.Event) -> None:
        """Nothing to decode ahead: a zoomed-out slice reads a coarse level."""

    def region(self, axis: Axis, index: int, rows: range, cols: range) -> NDArray[np.uint8]:
        """Return a region of the slice at ``index`` along ``axis`` (as ``TiffStack.region``).

        Returns
        -------
        (len(rows), len(cols)[, S]) uint8
        """
        shape = region_shape(self.shape_zyx, self.samples, axis, index, rows, cols)
        row_axis, col_axis = PLANE[axis]
        if not len(rows) or not len(cols):
            return np.zeros(shape, dtype=np.uint8)
        level = self._level(axis, rows.step, cols.step)
        factors = self.factors[level]
        ni, ri, ci = _POSITION[axis], _POSITION[row_axis], _POSITION[col_axis]
        at = index // factors[ni]
        row_at = np.asarray(rows, dtype=np.int64) // factors[ri]
        col_at = np.asarray(cols, dtype=np.int64) // factors[ci]
        box = [(0, 0)] * 3
        box[ni] = (at, at + 1)
        box[ri] = (int(row_at[0]), int(row_at[-1]) + 1)
        box[ci] = (int(col_at[0]), int(col_at[-1]) + 1)
        strided = rows.step % factors[ri] == 0 and cols.step % factors[ci] == 0
        planes = None  # along the normal: whole chunks
        limit = self.cache.budget_bytes // BAND_SHARE
        if strided and self._band_bytes(level, box) > limit:
            planes = THIN_PLANES
            while planes > 1 and self._band_bytes(level, box, ni, planes) > limit:
                planes //= 2
        if planes == 1:  # even one plane of the band is too large: read the slice alone
            steps = [1, 1, 1]
            steps[ri], steps[ci] = rows.step // factors[ri], cols.step // factors[ci]
            selection = tuple(slice(lo, hi, st) for (lo, hi), st in zip(box, steps, strict=True))
            lead = (slice(None),) if self.samples else ()
            values = np.asarray(self.levels[level][(*lead, *selection)])
            return _interleaved(values, self.samples).reshape(shape)
        band, origin = self._band(level, axis, box, ni, planes)
        picks: list[Any] = [None, None, None]
        picks[ni] = np.array([at - origin[ni]])
        picks[ri] = row_at - origin[ri]
        picks[ci] = col_at - origin[ci]
        values = _pick(band, picks, lead=1 if self.samples else 0)
        return _interleaved(values, self.samples).reshape(shape)

    @property
    def page_block(self) -> int:
        """Rows of level 0's chunks: :meth:`pages` of a whole block decode each chunk once."""
        return int(self.levels[0].chunks[-3])

    @property
    def row_block(self) -> int:
        """Rows of level 0's chunks: strips of whole chunks decode each chunk once."""
        return int(self.levels[0].chunks[-2])

    def pages(self, z0: int, z1: int, y0: int = 0, y1: int | None = None) -> NDArray[np.uint8]:
        """Return rows ``y0 <= y < y1`` (default: all) of the z pages ``z0 <= z < z1``.

        Returns
        -------
        (z1 - z0, y1 - y0, X[, S]) uint8
        """
        array = self.levels[0]
        rows = slice(y0, y1)
        values = np.asarray(array[:, z0:z1, rows] if self.samples else array[z0:z1, rows])
        return _interleaved(values, self.samples)

    def voxel(self, z: int, y: int, x: int) -> NDArray[np.uint8]:
        """Return voxel ``(z, y, x)`` of level 0: ``(S,)`` uint8 (``(1,)`` for labels)."""
        array = self.levels[0]
        value = array[:, z, y, x] if self.samples else array[z, y, x]
        return np.asarray(value, dtype=np.uint8).reshape(-1)

    def _level(self, axis: Axis, row_step: int, col_step: int) -> int:
        """Return the coarsest level whose voxel fits the steps (see the module)."""
        row_axis, col_axis = PLANE[axis]
        limit: dict[str, int] = {
            axis: max(row_step, col_step),
            row_axis: row_step,
            col_axis: col_step,
        }
        best = 0
        for level, factors in enumerate(self.factors):
            if all(factors[_POSITION[a]] <= limit[a] for a in "zyx"):
                best = level
        return best

    def _aligned(
        self, level: int, box: list[tuple[int, int]], normal: int, planes: int | None
    ) -> tuple[tuple[int, int], ...]:
        """Return `box` widened to whole chunks of `level` (along `normal` to `planes`)."""
        array = self.levels[level]
        aligned = []
        for k, ((lo, hi), ch, n) in enumerate(
            zip(box, array.chunks[-3:], array.shape[-3:], strict=True)
        ):
            size = planes if k == normal and planes is not None else ch
            aligned.append((lo // size * size, min(n, -(-hi // size) * size)))
        return tuple(aligned)

    def _band_bytes(
        self, level: int, box: list[tuple[int, int]], normal: int = 0, planes: int | None = None
    ) -> int:
        """Bytes of the band holding `box` at `level` (see :meth:`_aligned`)."""
        size = self.pixel_bytes
        for lo, hi in self._aligned(level, box, normal, planes):
            size *= hi - lo
        return size

    def _band(
        self, level: int, axis: Axis, box: list[tuple[int, int]], normal: int, planes: int | None
    ) -> tuple[NDArray[np.uint8], tuple[int, int, int]]:
        """Return the band holding `box` at `level` (cached) and its first voxel."""
        key: BandKey = (id(self), level, axis, tuple(box))
        found = self.cache.find(key)
        if found is not None:
            kept, band = found
            return band, (kept[3][0][0], kept[3][1][0], kept[3][2][0])
        aligned = self._aligned(level, box, normal, planes)
        selection = tuple(slice(lo, hi) for lo, hi in aligned)
        array = self.levels[level]
        band = np.asarray(array[(slice(None), *selection) if self.samples else selection])
        self.cache.put((id(self), level, axis, aligned), band)
        return band, (aligned[0][0], aligned[1][0], aligned[2][0])


def _pick(band: NDArray[np.uint8], picks: Sequence[NDArray[np.int64]], lead: int) -> Any:
    """Return ``band``'s voxels at the ``(z, y, x)`` index arrays ``picks`` (increasing).

    Evenly spaced indices are taken as slices (views), the others axis by axis; `lead`
    axes (the channels) come first and are kept whole.
    """
    values: Any = band
    for k, at in enumerate(picks):
        where: list[Any] = [slice(None)] * (lead + k)
        gaps = np.diff(at)
        if len(at) == 1 or (gaps[0] > 0 and np.all(gaps == gaps[0])):
            step = int(gaps[0]) if len(at) > 1 else 1
            values = values[(*where, slice(int(at[0]), int(at[-1]) + 1, step))]
        else:
            values = np.take(values, at, axis=lead + k)
    return values


def _interleaved(values: NDArray[np.uint8], samples: int) -> NDArray[np.uint8]:
    """Return ``(S, ...)`` channels as one contiguous ``(..., S)`` array (labels as they are).

    Channel by channel: a few times quicker than copying the moved axis.
    """
    if not samples:
        return np.ascontiguousarray(values)
    return np.stack(list(values), axis=-1)


def _open_levels(
    path: Path, shape_zyx: tuple[int, int, int], samples: int
) -> tuple[list[Any], list[tuple[int, int, int]]]:
    """Return the levels' arrays and their ``(z, y, x)`` factors from level 0, checked."""
    try:
        group: Any = zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r")
        ome: Any = group.attrs["ome"]
        (multiscale, *_) = ome["multiscales"]
        datasets = multiscale["datasets"]
        arrays: list[Any] = [group[str(d["path"])] for d in datasets]
        scales: list[Any] = [
            next(t["scale"] for t in d["coordinateTransformations"] if t["type"] == "scale")
            for d in datasets
        ]
    except (KeyError, TypeError, ValueError, OSError, StopIteration) as error:
        raise StackError(f"{path}: not an OME-Zarr image of a build ({error!r})") from None
    lead = (samples,) if samples else ()
    if not arrays or arrays[0].shape != (*lead, *shape_zyx):
        found = arrays[0].shape if arrays else None
        raise StackError(f"{path}: level 0 is {found}, not {(*lead, *shape_zyx)}")
    if any(a.dtype != np.uint8 or a.ndim != len(lead) + 3 for a in arrays):
        raise StackError(f"{path}: levels must be uint8 with {len(lead) + 3} axes")
    base = np.asarray(scales[0][-3:], dtype=np.float64)
    factors = []
    for scale in scales:
        ratio = np.rint(np.asarray(scale[-3:], dtype=np.float64) / base).astype(int)
        factors.append((int(ratio[0]), int(ratio[1]), int(ratio[2])))
    return arrays, factors
