"""GrabCAD Voxel Print jobs (``.gcvf``) streamed slab by slab (serialisation only).

A job is a zip of one PNG per slice, a box, a height map and a surface mesh, and
``ConfigFile.xml``. No specification is public; what follows is what public writers and
readers do (jackcrane/slice2vox ``buildGCVF.js`` and OpenVCAD 3.1 write jobs,
jackcrane/voxelprint-preview ``parseGCVF.js`` reads them, iwaag/vdbmat-utils
``docs/print-slices.md`` cites Stratasys's *Guide to Voxel Printing*; owner/name is a
GitHub repository, OpenVCAD the PyPI package ``openvcad``). *Inferred* marks what none of
them states and this writer chose. Every entry has one fixed timestamp: equal builds give
equal jobs, byte for byte.

Slices
------
- ``layer_N.png``, ``N`` = 0, 1, ... without zero padding and without gaps (slice2vox
  renames padded names and refuses gaps), one per z row of the grid; ``layer_0`` is the
  lowest z, printed first (*inferred*: the printer builds upwards).
- ``SliceWidth x SliceHeight`` = ``X x Y`` voxels: image columns are x (600 dpi, the
  printer's fine axis), rows are y (300 dpi). All slices have the same size.
- 32-bit RGBA, 8 bits per sample, straight alpha. Palette PNGs are reported to be
  refused by the import utility (vdbmat-utils notes), so none is written.
- A pixel is its voxel's material key, exactly: no other colour ever appears (the
  utility reports "Too many colors" for intermediate ones). Void (material index 0) is
  the background key.
- Orientation (*inferred*; GrabCAD's convention is not public): with the default
  ``first_row="max_y"`` pixel ``(row r, column c)`` of ``layer_N`` is voxel
  ``(z=N, y=Y-1-r, x=c)``, so each slice looks like the model seen from above (x to the
  right, y up) in any image viewer: a right-handed picture, so the print is not mirrored
  if the software shows slices as a top view. ``first_row="min_y"`` stores voxel row
  ``y = r`` (as ``materials.tif`` does) for a printer that turns out to read it so.
- Rows are stored unfiltered and deflated at level 1 (:mod:`shellvox.voxel.io._png_encode`, several
  slices in parallel threads); the zip stores the PNGs as they are (``ZIP_STORED``):
  deflating them again makes the job about 15 % smaller for a quarter more time.
- Fewer than `min_slices` (30) slices are padded with empty slices on top (higher z);
  :attr:`GcvfWriter.n_padding_slices` and the summary report how many.

``ConfigFile.xml``, the material table, the box, height map and surface, and the limits:
:mod:`shellvox.voxel.io._gcvf_job`.
"""

from __future__ import annotations

import contextlib
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io._gcvf_job import (
    BOX_NAME,
    IMAGE_PREFIX,
    RGBA,
    SURFACE_NAME,
    ZBUFFER_NAME,
    Material,
    box_bytes,
    check_grid,
    config_xml,
    key_rgba,
    material_table,
    raise_heights,
    surface_stl,
    zbuffer_png,
)
from shellvox.voxel.io._png_encode import encode_indexed_png
from shellvox.voxel.io._slab_thread import FirstRow, SliceWriter

CONFIG_NAME = "ConfigFile.xml"
#: Zip entries get one fixed timestamp, so equal jobs are equal files.
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


@dataclass(frozen=True)
class GcvfSummary:
    """What a finished job holds.

    Attributes
    ----------
    n_slices : int
        ``layer_N.png`` files (``NumberOfSlices``), padding included.
    n_padding_slices : int
        Empty slices added on top to reach `min_slices`.
    slice_width, slice_height : int
        Pixels along x and y.
    materials : tuple of (Material, int)
        The materials listed in ``ConfigFile.xml`` with their ``VoxelCount``.
    voxel_counts : dict of int to int
        Voxels per material index over the model's slices (index 0: void).
    files : tuple of str
        The zip's entries besides the slices, in order.
    """

    n_slices: int
    n_padding_slices: int
    slice_width: int
    slice_height: int
    materials: tuple[tuple[Material, int], ...]
    voxel_counts: dict[int, int]
    files: tuple[str, ...] = ()


class GcvfWriter(SliceWriter):
    """Write a ``.gcvf`` job from ``(Zs, Y, X)`` uint8 material-index slabs (module docstring).

    Parameters
    ----------
    path : Path
        Zip file to write (the caller may write it under a temporary name and rename it;
        an aborted writer removes it).
    grid : GridSpec
        Gives the slice size ``X x Y`` and the number of slices ``Z``; its voxel size must
        be ``25.4 / dpi`` mm in x and y and the slice thickness in z.
    materials : sequence of (int, str, (4,) int)
        ``(index, name, rgba_key)`` of every material the voxels may hold: index 1..255,
        keys 0..255; the name is the one the job lists (GrabCAD's short name). Index 0 is
        void; it may be listed only with the background key.
    background_rgba : (4,) int
        Key of void voxels (``BackGroundMaterialRGBA``): transparent black by default.
    dpi : (2,) int
        ``(XDpi, YDpi)``.
    slice_thickness_nm : int
        ``SliceThicknessNanoMeter``.
    max_materials : int
        Most non-background materials a job may list (6; 3 in high-speed mode).
    min_slices : int
        Fewer slices are padded with empty ones on top.
    tray_mm : (3,) float, mm, optional
        Printer build volume ``(x, y, z)``; a larger job is refused.
    first_row : {"max_y", "min_y"}
        Which end of the y axis is image row 0 (see Orientation in the module docstring).
    surface : ((V, 3) float64 mm, (F, 3) int64), optional
        The part's surface in the grid's world frame, written as ``Mesh.stl``.
    threads : int
        Slices encoded in parallel (zlib releases the GIL).
    level : int
        zlib level of the PNG data (1: fast; the slices are mostly long runs).
    queue_slabs : int
        Slabs that may wait for the writer thread.

    Raises
    ------
    GcvfJobError
        When a limit is broken (before the file is created).

    Examples
    --------
    >>> table = [(1, "VeroCY-V", (0, 255, 255, 255)), (2, "VeroPureWht", (255,) * 4)]
    >>> with GcvfWriter(path, grid, table) as job:  # doctest: +SKIP
    ...     for slab in slabs:
    ...         job.write_slab(slab)
    >>> job.summary.n_slices  # doctest: +SKIP
    """

    def __init__(
        self,
        path: str | Path,
        grid: GridSpec,
        materials: Sequence[tuple[int, str, Sequence[int]]],
        *,
        background_rgba: Sequence[int] = (0, 0, 0, 0),
        dpi: tuple[int, int] = (600, 300),
        slice_thickness_nm: int = 27000,
        max_materials: int = 6,
        min_slices: int = 30,
        tray_mm: tuple[float, float, float] | None = None,
        first_row: FirstRow = "max_y",
        surface: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None,
        threads: int = 2,
        level: int | None = None,
        queue_slabs: int = 2,
    ) -> None:
        super().__init__(first_row, threads, level)
        if max_materials < 1 or min_slices < 1:
            raise ValueError(
                f"max_materials and min_slices must be >= 1, got {max_materials}, {min_slices}"
            )
        self.path = Path(path)
        self.grid = grid
        self.dpi = (int(dpi[0]), int(dpi[1]))
        self.slice_thickness_nm = int(slice_thickness_nm)
        self.max_materials = int(max_materials)
        self.background = key_rgba(background_rgba, "background_rgba")
        self.materials = material_table(materials, self.background, self.max_materials)
        check_grid(grid, self.dpi, self.slice_thickness_nm, min_slices, tray_mm)
        n_z = grid.shape_zyx[0]
        self.n_padding_slices = max(0, min_slices - n_z)
        self.slice_encoder = KeySlices.of(self.materials, self.background, first_row, level)
        self._known = np.zeros(256, dtype=bool)
        self._indices = (0, *(m.index for m in self.materials))
        self._known[list(self._indices)] = True
        self._counts = np.zeros(256, dtype=np.int64)
        self._heights = np.full(grid.shape_zyx[1:], -1, dtype=np.int32)
        self._surface = surface
        self._next_z = 0
        self.summary: GcvfSummary | None = None
        # Every check is done: now the file is created.
        self._zip: zipfile.ZipFile | None = zipfile.ZipFile(
            self.path, "w", compression=zipfile.ZIP_STORED, allowZip64=True
        )
        self._start_slices(f"{self.path}", queue_slabs)

    @property
    def n_slices(self) -> int:
        """``NumberOfSlices``: the grid's z rows plus the padding."""
        return self.grid.shape_zyx[0] + self.n_padding_slices

    def write_slab(self, materials: NDArray[np.uint8]) -> None:
        """Queue the next slab of material indices.

        Parameters
        ----------
        materials : (Zs, Y, X) uint8
            Material index per voxel (0: void), the next ``Zs`` z rows in order. Every
            index must be in the material table.
        """
        _, n_y, n_x = self.grid.shape_zyx
        if materials.dtype != np.uint8 or materials.ndim != 3 or materials.shape[1:] != (n_y, n_x):
            raise ValueError(
                f"materials must be uint8 (Zs, {n_y}, {n_x}), got {materials.dtype} "
                f"{materials.shape}"
            )
        if self._next_z + len(materials) > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} slices written")
        if self._zip is None:
            raise ValueError(f"{self.path} is closed")
        counts = np.zeros(256, dtype=np.int64)
        # One comparison per material and slice: 3x faster than a bincount (which widens
        # every index to intp), and the temporaries stay the size of a slice.
        for plane in materials:
            for index in self._indices:
                counts[index] += np.count_nonzero(plane == index)
        if counts.sum() != materials.size:
            present = np.unique(materials)
            unknown = present[~self._known[present]]
            raise ValueError(
                f"slices {self._next_z}..{self._next_z + len(materials) - 1} hold material "
                f"indices {unknown.tolist()} that are not in the material table "
                f"{[m.index for m in self.materials]}"
            )
        slab = np.ascontiguousarray(materials)
        self._thread.put((self._next_z, slab))
        raise_heights(self._heights, slab, self._next_z)
        self._counts += counts
        self._next_z += len(materials)

    def write_encoded(
        self, slices: list[bytes], counts: NDArray[np.int64], materials: NDArray[np.uint8]
    ) -> None:
        """Queue the next slices, already encoded by :attr:`slice_encoder`.

        Parameters
        ----------
        slices : list of bytes
            The PNG files of the next ``Zs`` slices, in z order.
        counts : (256,) int64
            Voxels of each material index in those slices.
        materials : (Zs, Y, X) uint8
            Their material indices (for the height map, ``Zbuffer.png``).
        """
        if materials.shape != (len(slices), *self.grid.shape_zyx[1:]):
            raise ValueError(
                f"materials must be ({len(slices)}, {self.grid.shape_zyx[1]}, "
                f"{self.grid.shape_zyx[2]}), got {materials.shape}"
            )
        if self._next_z + len(slices) > self.grid.shape_zyx[0]:
            raise ValueError(f"more than Z={self.grid.shape_zyx[0]} slices written")
        if self._zip is None:
            raise ValueError(f"{self.path} is closed")
        unknown = np.flatnonzero((counts > 0) & ~self._known)
        if len(unknown):
            raise ValueError(
                f"slices {self._next_z}..{self._next_z + len(slices) - 1} hold material "
                f"indices {unknown.tolist()} that are not in the material table "
                f"{[m.index for m in self.materials]}"
            )
        self._thread.put((self._next_z, slices))
        raise_heights(self._heights, np.ascontiguousarray(materials, np.uint8), self._next_z)
        self._counts += counts
        self._next_z += len(slices)

    def close(self) -> GcvfSummary:
        """Write the padding, the box, height map and surface, ``ConfigFile.xml``; finish.

        Returns
        -------
        GcvfSummary
            Also kept as :attr:`summary`.

        Raises
        ------
        ValueError
            If fewer than ``Z`` slices were written (the file is removed).
        """
        if self.summary is not None:
            return self.summary
        try:
            if self._next_z != self.grid.shape_zyx[0]:
                raise ValueError(
                    f"{self.path}: {self._next_z} of {self.grid.shape_zyx[0]} slices written"
                )
            self._thread.finish()
            assert self._zip is not None
            _, n_y, n_x = self.grid.shape_zyx
            if self.n_padding_slices:
                empty = self._encode(np.zeros((n_y, n_x), dtype=np.uint8))
                for z in range(self.grid.shape_zyx[0], self.n_slices):
                    self._add(f"{IMAGE_PREFIX}{z}.png", empty)
            self._add(BOX_NAME, box_bytes(n_x, n_y, self.n_slices))
            bottom_up = self.first_row == "max_y"
            self._add(ZBUFFER_NAME, zbuffer_png(self._heights, bottom_up=bottom_up))
            if self._surface is not None:
                self._add(SURFACE_NAME, surface_stl(*self._surface, self.grid), deflate=True)
            listed = tuple(
                (material, int(self._counts[material.index]))
                for material in self.materials
                if self._counts[material.index] > 0
            )
            self._add(
                CONFIG_NAME,
                config_xml(
                    self.grid,
                    self.dpi,
                    self.slice_thickness_nm,
                    self.n_slices,
                    self.max_materials,
                    self.background,
                    listed,
                ),
                deflate=True,
            )
            self._zip.close()
            self._zip = None
            self._shutdown_pool()
        except BaseException:
            self.abort()
            raise
        self.summary = GcvfSummary(
            n_slices=self.n_slices,
            n_padding_slices=self.n_padding_slices,
            slice_width=n_x,
            slice_height=n_y,
            materials=listed,
            voxel_counts={int(i): int(self._counts[i]) for i in np.flatnonzero(self._counts)},
            files=(
                BOX_NAME,
                ZBUFFER_NAME,
                *([SURFACE_NAME] * (self._surface is not None)),
                CONFIG_NAME,
            ),
        )
        return self.summary

    def abort(self) -> None:
        """Stop the threads and remove the unfinished file."""
        self._stop_slices()
        if self._zip is not None:
            with contextlib.suppress(Exception):  # a half-written zip is removed anyway
                self._zip.close()
            self._zip = None
            self.path.unlink(missing_ok=True)

    def _encode(self, plane: NDArray[np.uint8]) -> bytes:
        """One slice ``(Y, X)`` of indices -> PNG of keys, rows in the chosen order."""
        return self.slice_encoder.encode(plane)

    def _store(self, z: int, data: bytes) -> None:
        self._add(f"{IMAGE_PREFIX}{z}.png", data)

    def _add(self, name: str, data: bytes, *, deflate: bool = False) -> None:
        """Store `data` as entry `name` (deflated when asked: text and meshes)."""
        assert self._zip is not None
        info = _zip_info(name)
        if deflate:
            info.compress_type = zipfile.ZIP_DEFLATED
        self._zip.writestr(info, data)


@dataclass(frozen=True, eq=False)
class KeySlices:
    """A job's slice images as a pure function: material indices to a PNG of RGBA keys.

    What :class:`GcvfWriter` stores for each slice; slab workers call it where the
    materials are made, so the writer only stores the bytes (:meth:`GcvfWriter.write_encoded`).

    Parameters
    ----------
    lut : (256, 4) uint8
        The RGBA key of each material index.
    first_row : {"max_y", "min_y"}
        Which end of the y axis is image row 0.
    level : int or None
        Of the PNG data: None, the fast setting (:mod:`shellvox.voxel.io._compression`), or zlib's
        level.
    """

    lut: NDArray[np.uint8]
    first_row: FirstRow
    level: int | None

    @classmethod
    def of(
        cls, materials: Sequence[Material], background: RGBA, first_row: FirstRow, level: int | None
    ) -> KeySlices:
        """Return the encoder of a checked material table (:func:`material_table`)."""
        lut = np.zeros((256, 4), dtype=np.uint8)
        lut[0] = background
        for material in materials:
            lut[material.index] = material.rgba
        return cls(lut, first_row, level)

    def encode(self, plane: NDArray[np.uint8]) -> bytes:
        """One slice ``(Y, X)`` of indices -> PNG of keys, rows in the chosen order."""
        bottom_up = self.first_row == "max_y"
        return encode_indexed_png(plane, self.lut, bottom_up=bottom_up, level=self.level)


def _zip_info(name: str) -> zipfile.ZipInfo:
    info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
    info.external_attr = 0o644 << 16  # a regular file, rw-r--r--, when unpacked
    return info
