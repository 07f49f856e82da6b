"""Slice regions read from a build's OME-Zarr store (``stack.ome.zarr``), any axis.

An image of the store (the colour image at its root, ``labels/layers``,
``labels/materials``) is a pyramid of chunked arrays (what
:mod:`shellvox.voxel.io._zarr_writer` writes). Its OME-Zarr metadata is read with ``zarr``; its
voxels with TensorStore, whose compiled reader decodes a section's chunks on every core
(an x section of spot at 100 mm on a J750, level 2, 285 chunks: 0.06-0.12 s with zarr
3.1, 0.01-0.03 s with TensorStore; a whole level-0 x section 0.2-0.37 s against
0.04-0.06 s). A region asks for every ``step``-th voxel of its rows and columns: it is
read from the coarsest level whose voxels are no larger than that along the rows and the
columns, and no larger than the larger step along the slice's normal (a zoomed-out view
of a 5 G-voxel build reads a level of a few hundred megavoxels); at one voxel per pixel
it reads level 0. The level's voxel holding each asked-for voxel gives its value (the
mode of the labels, the colour layers' mean colour there).

Decoded chunks are kept in TensorStore's cache, one budget for the images of a build
(:func:`read_context`), so the next slices through the same chunks (a slice's
neighbours, the same region panned) are read from memory. Whole pages (:meth:`ZarrStack.pages`,
the server's opening pass over the build) are read apart, through a context of one
thread and no cache (:func:`bulk_context`): they neither queue ahead of the slices asked
for meanwhile nor push their chunks out of the cache (read through the one context, a
colour section along x took up to 0.45 s while the pass ran, against 0.06 s after it).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray

from shellvox.viewer._stacks import PLANE, Axis, StackError, region_shape


def _tensorstore() -> Any:
    """TensorStore, imported on first use: only a store's reads need it."""
    import tensorstore

    return tensorstore


#: Memory for the decoded chunks kept between requests, bytes.
CACHE_BYTES = 1 << 30

#: The axes of a slice's rows and columns (and their positions in ``(z, y, x)``).
_POSITION = {"z": 0, "y": 1, "x": 2}


def read_context(budget_bytes: int = CACHE_BYTES) -> Any:
    """Return a TensorStore context whose decoded-chunk cache holds `budget_bytes`."""
    return _tensorstore().Context({"cache_pool": {"total_bytes_limit": int(budget_bytes)}})


def bulk_context() -> Any:
    """Return a TensorStore context for whole pages: one thread, no cache."""
    return _tensorstore().Context(
        {
            "cache_pool": {"total_bytes_limit": 0},
            "data_copy_concurrency": {"limit": 1},
            "file_io_concurrency": {"limit": 1},
        }
    )


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
    context : tensorstore.Context, optional
        Where decoded chunks are kept (shared by a build's images); default: a new
        :func:`read_context`.

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
        context: Any = None,
    ) -> None:
        self.path = Path(path)
        self.shape_zyx = (int(shape_zyx[0]), int(shape_zyx[1]), int(shape_zyx[2]))
        self.samples = samples
        self.context = context if context is not None else read_context()
        self.levels, self.factors, self._chunks, self._pages = _open_levels(
            self.path, self.shape_zyx, samples, self.context, bulk_context()
        )

    @property
    def pixel_bytes(self) -> int:
        """Bytes per voxel (1, 3 or 4)."""
        return max(1, self.samples)

    def close(self) -> None:
        """Nothing stays open between reads (TensorStore opens the store's files per read)."""

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
        wanted: list[NDArray[np.int64]] = [np.zeros(0, np.int64)] * 3
        wanted[_POSITION[axis]] = np.array([index // factors[_POSITION[axis]]])
        for along, span in ((row_axis, rows), (col_axis, cols)):
            wanted[_POSITION[along]] = np.asarray(span, dtype=np.int64) // factors[_POSITION[along]]
        selection, picks = zip(*(_selection(at) for at in wanted), strict=True)
        lead = (slice(None),) if self.samples else ()
        values = _pick(self._read(level, (*lead, *selection)), picks, lead=len(lead))
        return _interleaved(values, self.samples).reshape(shape)

    @property
    def page_block(self) -> int:
        """Rows of level 0's chunks: :meth:`pages` of a whole block decode each chunk once."""
        return self._chunks[0]

    @property
    def row_block(self) -> int:
        """Rows of level 0's chunks: strips of whole chunks decode each chunk once."""
        return self._chunks[1]

    def pages(self, z0: int, z1: int, y0: int = 0, y1: int | None = None) -> NDArray[np.uint8]:
        """Return rows ``y0 <= y < y1`` (default: all) of the z pages ``z0 <= z < z1``.

        Returns
        -------
        (z1 - z0, y1 - y0, X[, S]) uint8
        """
        y1 = self.shape_zyx[1] if y1 is None else y1
        lead = (slice(None),) if self.samples else ()
        values = self._read(0, (*lead, slice(z0, z1), slice(y0, y1), slice(None)), self._pages)
        return _interleaved(values, self.samples)

    def voxel(self, z: int, y: int, x: int) -> NDArray[np.uint8]:
        """Return voxel ``(z, y, x)`` of level 0: ``(S,)`` uint8 (``(1,)`` for labels)."""
        lead = (slice(None),) if self.samples else ()
        return self._read(0, (*lead, z, y, x)).astype(np.uint8).reshape(-1)

    def _read(self, level: int, selection: tuple[Any, ...], array: Any = None) -> NDArray[np.uint8]:
        """Return ``selection`` of `level` (NumPy indexing), decoded.

        From `array` if given: that level opened in another context.
        """
        source = self.levels[level] if array is None else array
        try:
            return np.asarray(source[selection].read().result())
        except ValueError as error:
            raise StackError(f"{self.path}: level {level} cannot be read ({error})") from None

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


def _selection(at: NDArray[np.int64]) -> tuple[slice, NDArray[np.int64] | None]:
    """Return a slice reading the increasing indices `at`, and what to pick from it after.

    Evenly spaced indices are read as a strided slice (nothing to pick); the others as the
    span holding them, picked from afterwards.
    """
    gaps = np.diff(at)
    if len(at) == 1 or (gaps[0] > 0 and np.all(gaps == gaps[0])):
        step = int(gaps[0]) if len(at) > 1 else 1
        return slice(int(at[0]), int(at[-1]) + 1, step), None
    return slice(int(at[0]), int(at[-1]) + 1), at - at[0]


def _pick(values: NDArray[np.uint8], picks: Sequence[NDArray[np.int64] | None], lead: int) -> Any:
    """Return `values` at the index arrays `picks` along its last three axes (None: all)."""
    for k, at in enumerate(picks):
        if at is not None:
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
    path: Path, shape_zyx: tuple[int, int, int], samples: int, context: Any, bulk: Any
) -> tuple[list[Any], list[tuple[int, int, int]], tuple[int, int], Any]:
    """Return the levels (TensorStore arrays), their factors, level 0's chunk rows, level 0.

    The last is level 0 opened again in the `bulk` context (for whole pages).

    The factors are each level's ``(z, y, x)`` voxel over level 0's; the chunk rows,
    ``(z, y)``. All are checked against the build's grid.
    """
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
    try:
        levels = [_open(path / str(d["path"]), context) for d in datasets]
        pages = _open(path / str(datasets[0]["path"]), bulk)
    except ValueError as error:
        raise StackError(f"{path}: TensorStore cannot open the levels ({error})") from None
    chunks = arrays[0].chunks[-3:]
    return levels, factors, (int(chunks[0]), int(chunks[1])), pages


def _open(path: Path, context: Any) -> Any:
    """Open one level's array for reading (TensorStore's ``zarr3`` driver)."""
    spec = {"driver": "zarr3", "kvstore": {"driver": "file", "path": str(path)}}
    return _tensorstore().open(spec, read=True, context=context).result()
