"""A folder of RGBA PNG slices (colour and translucency), streamed slab by slab.

For printers and tools that take colour slices rather than material keys: one
``slice_00000.png`` (zero-padded to at least 5 digits) per z row of the grid, lowest z
first, each ``X x Y`` pixels of 8-bit RGBA with straight (unassociated) alpha, and a
``slices.json`` sidecar giving the voxel size, the grid and the pixel mapping. Each PNG
also carries its pixel density (``pHYs``), so image tools show true size in x and y.

Orientation as in :mod:`shellvox.voxel.io._gcvf_writer`: with ``first_row="max_y"`` (default) pixel
``(row r, column c)`` of slice ``z`` is voxel ``(z, Y-1-r, c)``, so a slice looks like the
model seen from above; ``"min_y"`` stores row ``r`` = voxel row ``y = r``.

The folder appears whole or not at all: slices go into a temporary folder beside it
(``.NAME.*.partial``), renamed to NAME by :meth:`PngSliceWriter.close`. An existing NAME
is replaced (moved aside first, removed after the rename); :meth:`PngSliceWriter.abort`
removes the temporary folder.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io._png_encode import encode_png
from shellvox.voxel.io._slab_thread import FirstRow, SliceWriter

SIDECAR_NAME = "slices.json"
MM_PER_METRE = 1000.0
MM_PER_INCH = 25.4


class PngSliceWriter(SliceWriter):
    """Write ``(Zs, Y, X, 4)`` uint8 RGBA slabs as a folder of PNG slices.

    Parameters
    ----------
    folder : Path
        The folder to create (replaced if it exists).
    grid : GridSpec
        Number of slices, their size and the voxel size.
    first_row : {"max_y", "min_y"}
        Which end of the y axis is image row 0 (module docstring).
    metadata : mapping, optional
        Extra JSON-serialisable entries for the sidecar (e.g. what the colours mean).
    threads : int
        Slices encoded in parallel.
    level : int, optional
        Of the PNG data: None (default), the fast setting (:mod:`shellvox.voxel.io._compression`),
        or zlib's.
    queue_slabs : int
        Slabs that may wait for the writer thread.
    """

    def __init__(
        self,
        folder: str | Path,
        grid: GridSpec,
        *,
        first_row: FirstRow = "max_y",
        metadata: Mapping[str, Any] | None = None,
        threads: int = 2,
        level: int | None = None,
        queue_slabs: int = 2,
    ) -> None:
        super().__init__(first_row, threads, level)
        self.folder = Path(folder)
        self.grid = grid
        self.metadata = dict(metadata or {})
        json.dumps(self.metadata)  # refuse what the sidecar could not hold, before writing
        n_z = grid.shape_zyx[0]
        self.digits = max(5, len(str(n_z - 1)))
        vx, vy, _ = grid.voxel_mm
        self._ppm = (round(MM_PER_METRE / vx), round(MM_PER_METRE / vy))
        self._next_z = 0
        self._done = False
        self._temporary: Path | None = Path(
            tempfile.mkdtemp(
                prefix=f".{self.folder.name}.", suffix=".partial", dir=self.folder.parent
            )
        )
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self._temporary, 0o777 & ~umask)  # mkdtemp makes 0700; the usual mode
        self._start_slices(str(self.folder), queue_slabs)

    def name(self, z: int) -> str:
        """File name of slice `z`."""
        return f"slice_{z:0{self.digits}d}.png"

    def write_slab(self, rgba: NDArray[np.uint8]) -> None:
        """Queue the next slab.

        Parameters
        ----------
        rgba : (Zs, Y, X, 4) uint8
            sRGB colour and straight alpha (0: no material, 255: opaque), the next ``Zs``
            z rows in order.
        """
        _, n_y, n_x = self.grid.shape_zyx
        if rgba.dtype != np.uint8 or rgba.ndim != 4 or rgba.shape[1:] != (n_y, n_x, 4):
            raise ValueError(
                f"rgba must be uint8 (Zs, {n_y}, {n_x}, 4), got {rgba.dtype} {rgba.shape}"
            )
        if self._next_z + len(rgba) > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} slices written")
        if self._temporary is None:
            raise ValueError(f"{self.folder} is closed")
        self._thread.put((self._next_z, np.ascontiguousarray(rgba)))
        self._next_z += len(rgba)

    def close(self) -> None:
        """Write the sidecar and move the folder into place.

        Raises
        ------
        ValueError
            If fewer than ``Z`` slices were written (nothing is left behind).
        """
        if self._done:
            return
        try:
            if self._next_z != self.grid.shape_zyx[0]:
                raise ValueError(
                    f"{self.folder}: {self._next_z} of {self.grid.shape_zyx[0]} slices written"
                )
            self._thread.finish()
            self._shutdown_pool()
            assert self._temporary is not None
            sidecar = json.dumps(self._sidecar(), indent=1) + "\n"
            (self._temporary / SIDECAR_NAME).write_text(sidecar, encoding="utf-8")
            _replace_folder(self._temporary, self.folder)
            self._temporary = None
            self._done = True
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Stop the threads and remove the temporary folder."""
        self._stop_slices()
        if self._temporary is not None:
            shutil.rmtree(self._temporary, ignore_errors=True)
            self._temporary = None

    def _encode(self, plane: NDArray[np.uint8]) -> bytes:
        return encode_png(self._rows(plane), level=self._level, pixels_per_metre=self._ppm)

    def _store(self, z: int, data: bytes) -> None:
        assert self._temporary is not None
        (self._temporary / self.name(z)).write_bytes(data)

    def _sidecar(self) -> dict[str, Any]:
        n_z, n_y, n_x = self.grid.shape_zyx
        vx, vy, vz = self.grid.voxel_mm
        row = "Y - 1 - r" if self.first_row == "max_y" else "r"
        return {
            "format": "shellvox RGBA slices",
            "version": 1,
            "files": f"slice_%0{self.digits}d.png",
            "n_slices": n_z,
            "width": n_x,
            "height": n_y,
            "voxel_mm": [vx, vy, vz],
            "dpi": [MM_PER_INCH / vx, MM_PER_INCH / vy],
            "slice_thickness_mm": vz,
            "origin_mm": list(self.grid.origin_mm),
            "first_row": self.first_row,
            "pixel_to_voxel": f"slice z, row r, column c is voxel (z, y = {row}, x = c); "
            "slice 0 is the lowest z",
            "pixels": "8-bit sRGB with straight (unassociated) alpha; alpha 0 is no material",
            **self.metadata,
        }


def _replace_folder(source: Path, target: Path) -> None:
    """Rename `source` to `target`, replacing an existing `target` (moved aside first)."""
    old: Path | None = None
    if target.exists() or target.is_symlink():
        old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
        os.replace(target, old / target.name)
    os.replace(source, target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    try:
        directory = os.open(target.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(directory)
    finally:
        os.close(directory)
