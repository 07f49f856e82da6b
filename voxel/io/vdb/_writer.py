"""OpenVDB output streamed slab by slab, with memory bounded by the slab.

The grids share one linear transform carrying the anisotropic voxel size, so index
``(i, j, k) = (x, y, z)`` maps to the voxel centre in mm:

- ``density`` (float, fog volume): 1 inside the model, background 0;
- ``layer`` (float): the layer index, background 0;
- ``color`` (Vec3s): linear RGB of the colour layers, background 0;
- ``sdf`` (float, level set): signed distance to the outer surface in a narrow band,
  background the half width, inactive voxels inside at minus the half width (what
  OpenVDB's ``signedFloodFill`` gives);
- ``material`` (float, optional): the printer material index per voxel, active where it
  is not 0 (void), background 0. Float because OpenVDB 10's Python module registers
  only ``FloatGrid``, ``BoolGrid`` and ``Vec3SGrid``: with an int32 grid in the file its
  ``readAll`` and ``read`` refuse the whole file ("Tree_int32_5_4_3 is not a supported
  OpenVDB grid type"). Indices 0..255 are exact in float32.

Why not build the grids with OpenVDB's Python bindings and call ``openvdb.write``? Their
leaves cover the model's surface, and OpenVDB writes only whole in-memory grids: for spot
at 30 mm on the J750 grid they added 600 MB to the build's peak (1.02 GB), and 930 MB
when the model was twice as tall. Here each group of 8 rows is cut into 8^3 leaves as it
arrives; a leaf's buffer is encoded as OpenVDB stores it and appended to a spool file per
grid; blocks that are constant and wholly active (the core) or wholly inside the level
set without active voxels become tiles of their parent node. At the end the tree
topology (root, 4096^3 and 128^3 internal nodes, leaf masks) is assembled from the leaf
and tile lists, and the spooled buffers are copied in tree order. Memory is the slab plus
28 bytes per leaf and 16 per tile while streaming, and about 100 bytes per leaf of one
grid while the tree is assembled (sorted copies and sort keys).

The bytes (OpenVDB's file format 224) are written by :mod:`shellvox.voxel.io.vdb._format`. The tests
read the files back with OpenVDB's own reader and compare them voxel for voxel with grids
OpenVDB builds in memory from the same arrays.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io.vdb._encode import VdbEncoder, grid_kinds
from shellvox.voxel.io.vdb._format import write_file
from shellvox.voxel.io.vdb._leaves import LEAF, GridSpool


class VdbStackWriter:
    """Stream slabs into one ``.vdb`` file (see the module docstring).

    Parameters
    ----------
    grid : GridSpec
        The voxel grid (gives the transform and the shape).
    sdf_half_width_mm : float, mm
        Background value of the level set (its narrow-band half width).
    spool_dir : Path, optional
        Where the leaf spools go (default: the system's temporary folder); they are
        removed by :meth:`write` or :meth:`close`.
    compression_level : int, optional
        Of the leaf values: None (default), the fast setting of
        :mod:`shellvox.voxel.io._compression`, or zlib's level 1-9 (hardly smaller on these grids:
        constant densities, integer layers and texture colours). Level-set values hardly compress
        (about 0.92) and are stored raw.
    material_grid : bool, optional
        Also write the ``material`` grid; then every :meth:`write_slab` gives `materials`.

    Examples
    --------
    >>> writer = VdbStackWriter(grid, sdf_half_width_mm=0.1)  # doctest: +SKIP
    >>> writer.write_slab(0, layers, rgb, coloured, sdf)  # doctest: +SKIP
    >>> summary = writer.write(Path("volume.vdb"))  # doctest: +SKIP
    """

    def __init__(
        self,
        grid: GridSpec,
        *,
        sdf_half_width_mm: float,
        spool_dir: Path | None = None,
        compression_level: int | None = None,
        material_grid: bool = False,
    ) -> None:
        self.grid = grid
        self._level = compression_level
        self._half_width = np.float32(sdf_half_width_mm)
        self._dir = tempfile.TemporaryDirectory(prefix=".vdb-spool.", dir=spool_dir)
        self.material_grid = material_grid
        self._kinds = grid_kinds(float(self._half_width), material_grid)
        self._spools = [
            GridSpool(
                name,
                value_type,
                grid_class,
                background,
                open(os.path.join(self._dir.name, name), "w+b"),  # noqa: SIM115
            )
            for name, (value_type, grid_class, background) in self._kinds
        ]
        self._pending: list[tuple[NDArray[Any], ...]] = []  # rows of an unfinished leaf row
        self._next_z = 0

    def encoder(self) -> VdbEncoder:
        """Return the pure encoder of this writer's grids (picklable, for worker processes)."""
        return VdbEncoder(self.grid, self._kinds, float(self._half_width), self._level)

    def write_encoded(self, z_start: int, n_rows: int, spools: list[GridSpool]) -> None:
        """Append rows ``z_start .. z_start + n_rows`` encoded by :meth:`VdbEncoder.encode`.

        The rows must start where the last ones stopped, at a multiple of 8 (a leaf row),
        and end at a multiple of 8 or at the top of the grid.
        """
        if z_start != self._next_z or self._pending:
            raise ValueError(
                f"slabs must arrive in order: expected row {self._next_z}, got {z_start}"
            )
        stop = z_start + n_rows
        if z_start % LEAF or (stop % LEAF and stop != self.grid.shape_zyx[0]):
            raise ValueError(f"encoded rows {z_start}..{stop} are not whole leaf rows")
        for mine, theirs in zip(self._spools, spools, strict=True):
            mine.absorb(theirs)
        self._next_z = stop

    def write_slab(
        self,
        z_start: int,
        layers: NDArray[np.uint8],
        rgb: NDArray[np.uint8],
        coloured: NDArray[np.bool_],
        sdf: NDArray[np.float32],
        materials: NDArray[np.uint8] | None = None,
    ) -> None:
        """Take the next slab (slabs arrive in z order, without gaps).

        Parameters
        ----------
        z_start : int
            First row of the slab.
        layers : (Zs, Y, X) uint8
            Layer index; density is ``layers > 0``.
        rgb : (Zs, Y, X, 3) uint8
            sRGB colour, 0 outside the colour layers; stored as linear RGB.
        coloured : (Zs, Y, X) bool
            Voxels of the colour layers: active in ``color`` even where black.
        sdf : (Zs, Y, X) float32, mm
            Signed distance in the narrow band (``abs(sdf) < half width``); plus or
            minus the half width elsewhere (the sign is taken from `layers`).
        materials : (Zs, Y, X) uint8, optional
            Material index (0: void); given exactly when the writer has a material grid.
        """
        if (materials is not None) != self.material_grid:
            raise ValueError(
                "materials must be given exactly when the writer was made with "
                f"material_grid=True (material_grid={self.material_grid})"
            )
        if materials is not None and materials.shape != layers.shape:
            raise ValueError(
                f"materials must have the shape of layers {layers.shape}, got {materials.shape}"
            )
        if z_start != self._next_z:
            raise ValueError(
                f"slabs must arrive in order: expected row {self._next_z}, got {z_start}"
            )
        self._next_z = z_start + len(layers)
        arrays = (layers, rgb, coloured, sdf) + (() if materials is None else (materials,))
        self._pending.append(arrays)
        held = sum(len(p[0]) for p in self._pending)
        first = self._next_z - held
        # Whole groups of 8 rows (leaf rows, aligned to multiples of 8 in z) go out now.
        ready = (self._next_z // LEAF) * LEAF - first
        if self._next_z == self.grid.shape_zyx[0]:
            ready = held
        if ready <= 0:
            # Copies: a view would keep the caller's slab (a shared slot) alive until
            # the leaf row is complete, and slabs of fewer than 8 rows would hold them all.
            self._pending[-1] = tuple(part.copy() for part in arrays)
            return
        parts = (
            list(self._pending[0])
            if len(self._pending) == 1
            else [np.concatenate(arrays) for arrays in zip(*self._pending, strict=True)]
        )
        encoder = self.encoder()
        for z0 in range(0, ready, LEAF):
            rows = slice(z0, min(ready, z0 + LEAF))
            encoder.leaf_row(self._spools, first + z0, *(part[rows] for part in parts))
        # A copy: a view of the leftover rows would keep the whole slab alive.
        self._pending = [tuple(part[ready:].copy() for part in parts)] if ready < held else []

    def write(self, path: Path, metadata: dict[str, str] | None = None) -> dict[str, Any]:
        """Write all grids to `path`; return their summary and remove the spools.

        Returns
        -------
        dict
            Per grid name: ``class``, ``value_type``, ``active_voxels``, ``voxel_size_mm``.
        """
        try:
            if self._next_z != self.grid.shape_zyx[0]:
                raise ValueError(
                    f"{path}: only {self._next_z} of {self.grid.shape_zyx[0]} rows were written"
                )
            write_file(path, self._spools, self.grid, metadata or {})
        finally:
            self.close()
        return self.summary()

    def summary(self) -> dict[str, Any]:
        """Return ``{name: {class, value_type, active_voxels, voxel_size_mm}}``."""
        return {
            spool.name: {
                "class": spool.grid_class,
                "value_type": spool.value_type,
                "active_voxels": spool.active_voxels,
                "voxel_size_mm": [float(v) for v in self.grid.voxel_mm],
            }
            for spool in self._spools
        }

    def close(self) -> None:
        """Remove the spools (also done by :meth:`write`)."""
        for spool in self._spools:
            spool.stream.close()
        self._dir.cleanup()
