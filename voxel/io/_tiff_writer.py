"""Streaming ImageJ-compatible TIFF stacks, written slab by slab (serialisation only).

Each file is written by its own thread from a bounded queue, so the caller pushes slabs
(:meth:`TiffStackWriter.write_slab`) while compression runs beside the numerics; at most
``queue_slabs`` slabs wait in memory. Pages are ``(Y, X)`` (or ``(Y, X, S)`` RGB) planes,
one per z, deflate (zlib) compressed, with ImageJ metadata ``spacing`` (z), ``unit='mm'``
and TIFF resolution tags (pixels per mm in x and y) so Fiji shows true size.

Each page is one strip, compressed in the writer thread before tifffile writes it as
is: by default at the fast setting of :mod:`shellvox.voxel.io._compression` (zlib-ng, GIL released,
3 to 4 times zlib level 1's speed on voxel slices and smaller), or at a given zlib level
(smaller files, slower). Both are TIFF compression 8 (deflate).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import tifffile
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io._slab_thread import ClosingWriter, SlabThread
from shellvox.voxel.io._tiff_pages import compress_page

#: Classic TIFF holds at most 4 GiB; BigTIFF is chosen when the raw data could exceed this.
CLASSIC_TIFF_LIMIT = 2**32 - 2**26


class TiffStackWriter(ClosingWriter):
    """Write a ``(Z, Y, X[, S])`` uint8 stack to ``path`` one slab at a time.

    Parameters
    ----------
    path : Path
        File to write (the caller may write it under a temporary name and rename it).
    grid : GridSpec
        Gives the number of pages, page shape and physical voxel size.
    samples : int
        0 for a grey stack ``(Z, Y, X)``; 3 (RGB) or 4 (RGBA) for colour ``(Z, Y, X, S)``.
    compression_level : int, optional
        zlib level 1..9; None (default): the fast setting (:mod:`shellvox.voxel.io._compression`).
    queue_slabs : int
        Slabs that may wait for the writer thread.

    Notes
    -----
    ImageJ hyperstacks are specified without BigTIFF; past 4 GiB the file is a BigTIFF with
    the ImageJ description, which Fiji opens with Bio-Formats (:attr:`bigtiff` tells).
    """

    def __init__(
        self,
        path: Path,
        grid: GridSpec,
        *,
        samples: int = 0,
        compression_level: int | None = None,
        queue_slabs: int = 2,
    ) -> None:
        if samples not in (0, 3, 4):
            raise ValueError(f"samples must be 0, 3 or 4, got {samples}")
        if compression_level is not None and not 1 <= compression_level <= 9:
            raise ValueError(f"compression_level must be 1..9 or None, got {compression_level}")
        self.path = Path(path)
        self.grid = grid
        self.samples = samples
        _, n_y, n_x = grid.shape_zyx
        self.page_shape: tuple[int, ...] = (n_y, n_x) if samples == 0 else (n_y, n_x, samples)
        self.bigtiff = grid.n_voxels * max(samples, 1) > CLASSIC_TIFF_LIMIT
        self._level = compression_level
        self._pages_sent = 0
        self._thread: SlabThread[NDArray[np.uint8] | list[bytes]] = SlabThread.streaming(
            str(self.path), self._write, queue_slabs=queue_slabs
        )

    def write_slab(self, slab: NDArray[np.uint8]) -> None:
        """Queue the next ``(Zs, Y, X[, S])`` uint8 slab (pages in z order)."""
        if slab.dtype != np.uint8 or slab.shape[1:] != self.page_shape:
            raise ValueError(
                f"slab must be uint8 (Zs, {', '.join(map(str, self.page_shape))}), "
                f"got {slab.dtype} {slab.shape}"
            )
        if self._pages_sent + len(slab) > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} pages written")
        self._thread.put(slab)
        self._pages_sent += len(slab)

    def close(self) -> None:
        """Finish the file; raise if fewer than ``Z`` pages were written or writing failed."""
        self._thread.stop()
        if self._pages_sent != self.grid.shape_zyx[0]:
            raise ValueError(f"{self._pages_sent} of {self.grid.shape_zyx[0]} pages written")
        self._thread.raise_if_failed()

    def abort(self) -> None:
        """Stop the writer thread without finishing the file (the caller removes it)."""
        self._thread.abort()

    def write_pages(self, pages: list[bytes]) -> None:
        """Queue the next pages, already compressed, in z order.

        Each as :func:`shellvox.voxel.io._tiff_pages.compress_page` gives it with this writer's
        samples and level.
        """
        if self._pages_sent + len(pages) > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} pages written")
        self._thread.put(pages)
        self._pages_sent += len(pages)

    def _pages(self, slabs: Iterator[NDArray[np.uint8] | list[bytes]]) -> Iterator[bytes]:
        """Compressed pages (one strip each), in order, from the queued slabs."""
        for slab in slabs:
            if isinstance(slab, list):  # compressed where the slab was computed
                yield from slab
                continue
            for page in slab:
                yield compress_page(page, self._level)

    def _write(self, slabs: Iterator[NDArray[np.uint8] | list[bytes]]) -> None:
        """In the writer thread: the whole file, its pages compressed as the slabs come."""
        vx, vy, vz = self.grid.voxel_mm
        n_z = self.grid.shape_zyx[0]
        options: dict[str, Any] = {
            "shape": (n_z, *self.page_shape),
            "dtype": np.uint8,
            "compression": "zlib",
            "rowsperstrip": self.page_shape[0],
            "resolution": (1.0 / vx, 1.0 / vy),
            "metadata": {"spacing": vz, "unit": "mm", "axes": "ZYXS" if self.samples else "ZYX"},
        }
        if self.samples:
            options["photometric"] = "rgb"
            if self.samples == 4:
                options["extrasamples"] = ("unassalpha",)
        else:
            options["photometric"] = "minisblack"
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*nonconformant BigTIFF ImageJ")
            with tifffile.TiffWriter(self.path, bigtiff=self.bigtiff, imagej=True) as tiff:
                tiff.write(self._pages(slabs), **options)
