"""The grids of ``volume.vdb`` cut from voxel rows into 8^3 leaves and tiles (no files).

:class:`VdbEncoder` is a pure function of the rows, so the slab workers can encode their
slabs and :class:`voxel.vdb_writer.VdbStackWriter` only appends the results to its spools
(the grids are described in :mod:`voxel.vdb_writer`).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from numpy.typing import NDArray

from voxel.grid import GridSpec
from voxel.srgb import codes_to_linear
from voxel.vdb_leaves import LEAF, GridSpool

GRID_NAMES = ("density", "layer", "color", "sdf")
#: Grids whose leaves are runs of equal values (compressed by :mod:`voxel.deflate`).
RUN_GRIDS = ("density", "layer")
#: The optional grid of material indices (after GRID_NAMES in the file).
MATERIAL_GRID = "material"


def grid_kinds(half_width: float, material_grid: bool) -> list[tuple[str, tuple[str, str, float]]]:
    """Names and ``(value type, class, background)`` of the grids written."""
    kinds = [
        ("float", "fog volume", 0.0),
        ("float", "unknown", 0.0),
        ("vec3s", "unknown", 0.0),
        ("float", "level set", float(np.float32(half_width))),
    ]
    names = list(GRID_NAMES)
    if material_grid:
        names.append(MATERIAL_GRID)
        kinds.append(("float", "unknown", 0.0))
    return list(zip(names, kinds, strict=True))


class VdbEncoder:
    """Cuts groups of 8 rows into the leaves and tiles of every grid (no files).

    A pure function of the rows, so worker processes can encode their slabs
    (:meth:`encode`) and the writer only appends the results
    (:meth:`VdbStackWriter.write_encoded`). Made by :meth:`VdbStackWriter.encoder`.
    """

    def __init__(
        self,
        grid: GridSpec,
        kinds: list[tuple[str, tuple[str, str, float]]],
        half_width: float,
        level: int | None,
    ) -> None:
        self.grid = grid
        self._kinds = kinds
        self._half_width = np.float32(half_width)
        self._level = level

    @classmethod
    def for_grid(
        cls, grid: GridSpec, *, sdf_half_width_mm: float, material_grid: bool,
        compression_level: int | None = None,
    ) -> VdbEncoder:  # fmt: skip
        """Return the encoder of a :class:`VdbStackWriter` made with the same arguments."""
        kinds = grid_kinds(float(np.float32(sdf_half_width_mm)), material_grid)
        return cls(grid, kinds, sdf_half_width_mm, compression_level)

    def encode(
        self,
        z_start: int,
        layers: NDArray[np.uint8],
        rgb: NDArray[np.uint8],
        coloured: NDArray[np.bool_],
        sdf: NDArray[np.float32],
        materials: NDArray[np.uint8] | None = None,
    ) -> list[GridSpool]:
        """Return in-memory spools of rows ``z_start ..`` (whole leaf rows, see writer)."""
        spools = [
            GridSpool(name, value_type, grid_class, background, io.BytesIO())
            for name, (value_type, grid_class, background) in self._kinds
        ]
        if (materials is None) != (len(spools) == 4):
            raise ValueError("materials must be given exactly when there is a material grid")
        for z0 in range(0, len(layers), LEAF):
            rows = slice(z0, z0 + LEAF)
            self.leaf_row(
                spools, z_start + z0, layers[rows], rgb[rows], coloured[rows], sdf[rows],
                None if materials is None else materials[rows],
            )  # fmt: skip
        return spools

    def leaf_row(
        self,
        spools: list[GridSpool],
        z0: int,
        layers: NDArray[np.uint8],
        rgb: NDArray[np.uint8],
        coloured: NDArray[np.bool_],
        sdf: NDArray[np.float32],
        materials: NDArray[np.uint8] | None = None,
    ) -> None:
        """Cut rows ``z0 .. z0 + 8`` (fewer at the top) into leaves and tiles of every grid.

        Blocks are classified from reductions over the rows and then over 8 x 8 columns;
        only the blocks that become leaves are gathered, reordered and converted.
        """
        hw = self._half_width
        inside = layers > 0
        in_band = np.abs(sdf) < hw
        # Only the columns holding non-background voxels, from a multiple of 8 on.
        content = (inside | in_band).any(axis=0)
        if materials is not None:  # void is outside; any other material counts as content
            content |= (materials > 0).any(axis=0)
        ys = np.flatnonzero(content.any(axis=1))
        if len(ys) == 0:
            return
        xs = np.flatnonzero(content.any(axis=0))
        n_y, n_x = content.shape
        y0, x0 = int(ys[0]) // LEAF * LEAF, int(xs[0]) // LEAF * LEAF
        y1 = min(n_y, -(-(int(ys[-1]) + 1) // LEAF) * LEAF)
        x1 = min(n_x, -(-(int(xs[-1]) + 1) // LEAF) * LEAF)
        box = (slice(None), slice(y0, y1), slice(x0, x1))
        blocks = _Blocks((x0, y0, z0))
        layers = blocks.pad(layers[box], 0)
        rgb = blocks.pad(rgb[box], 0)
        coloured = blocks.pad(coloured[box], False)
        sdf = blocks.pad(sdf[box], hw)
        inside, in_band = blocks.pad(inside[box], False), blocks.pad(in_band[box], False)
        any_in, all_in = blocks.any(inside), blocks.all(inside)
        any_band = blocks.any(in_band)
        low, high = blocks.reduce(layers, np.min), blocks.reduce(layers, np.max)
        density, layer, color, level = spools[:4]
        # density and layer: the core's constant blocks are active tiles.
        density.add_tiles(blocks.origins(all_in), np.ones(int(all_in.sum()), np.float32), True)
        self._leaves(density, blocks, any_in & ~all_in, inside, inside)
        tile = all_in & (low == high)
        layer.add_tiles(blocks.origins(tile), low[tile].astype(np.float32), True)
        self._leaves(layer, blocks, any_in & ~tile, layers, inside)
        # color: leaves wherever a colour voxel is; black ones stay active (background 0).
        leaf = blocks.any(coloured)
        linear = codes_to_linear(blocks.gather(rgb, leaf))
        on = blocks.gather(coloured, leaf)
        linear[on] = np.maximum(linear[on], np.float32(1e-7))
        color.add_leaves(blocks.origins(leaf), linear, on, None, self._level)
        # sdf: inactive values are -hw inside, +hw (the background) outside.
        tile = all_in & ~any_band
        level.add_tiles(blocks.origins(tile), np.full(int(tile.sum()), -hw), False)
        leaf = any_band | (any_in & ~all_in)
        band, solid = blocks.gather(in_band, leaf), blocks.gather(inside, leaf)
        values = np.where(band, blocks.gather(sdf, leaf), np.where(solid, -hw, hw))
        # Level-set values hardly compress (about 0.92): stored raw.
        level.add_leaves(blocks.origins(leaf), values.astype(np.float32), band, solid, 0)
        if materials is not None:
            # material: like layer, constant wholly non-void blocks are active tiles.
            materials = blocks.pad(materials[box], 0)
            solid = materials > 0
            any_on, all_on = blocks.any(solid), blocks.all(solid)
            low, high = blocks.reduce(materials, np.min), blocks.reduce(materials, np.max)
            tile = all_on & (low == high)
            spools[4].add_tiles(blocks.origins(tile), low[tile].astype(np.float32), True)
            self._leaves(spools[4], blocks, any_on & ~tile, materials, solid)

    def _leaves(
        self,
        spool: GridSpool,
        blocks: _Blocks,
        which: NDArray[np.bool_],
        values: NDArray[Any],
        active: NDArray[np.bool_],
    ) -> None:
        """Spool the blocks `which` of a grid whose inactive values are its background."""
        spool.add_leaves(
            blocks.origins(which),
            blocks.gather(values, which).astype(np.float32),
            blocks.gather(active, which),
            None,
            self._level,
            spool.name in RUN_GRIDS,
        )


class _Blocks:
    """8^3 blocks of a group of rows ``(8, Y, X[, 3])`` (Y, X multiples of 8) at `corner`.

    Reductions run on the blocked view ``(8, Y/8, 8, X/8, 8)`` without copies; gathered
    leaves are in OpenVDB's voxel order ``x << 6 | y << 3 | z``.
    """

    def __init__(self, corner: tuple[int, int, int]) -> None:
        self.corner = corner  # (x, y, z) index of the first voxel

    @staticmethod
    def pad(volume: NDArray[Any], fill: Any) -> NDArray[Any]:
        """Pad ``(Zs <= 8, Ys, Xs[, 3])`` to whole blocks with `fill`."""
        pads = [
            (0, LEAF - volume.shape[0]),
            (0, -volume.shape[1] % LEAF),
            (0, -volume.shape[2] % LEAF),
        ] + [(0, 0)] * (volume.ndim - 3)
        if any(after for _, after in pads):
            return np.pad(volume, pads, constant_values=fill)
        return volume

    @staticmethod
    def view(volume: NDArray[Any]) -> NDArray[Any]:
        _, n_y, n_x = volume.shape[:3]
        return volume.reshape(LEAF, n_y // LEAF, LEAF, n_x // LEAF, LEAF, *volume.shape[3:])

    def reduce(self, volume: NDArray[Any], how: Any) -> NDArray[Any]:
        """Return ``how`` over each block: ``(Y/8, X/8)`` (over the rows first, contiguous)."""
        columns = how(volume, axis=0)
        n_y, n_x = columns.shape
        return np.asarray(how(columns.reshape(n_y // LEAF, LEAF, n_x // LEAF, LEAF), axis=(1, 3)))

    def any(self, volume: NDArray[np.bool_]) -> NDArray[np.bool_]:
        return self.reduce(volume, np.any)

    def all(self, volume: NDArray[np.bool_]) -> NDArray[np.bool_]:
        return self.reduce(volume, np.all)

    def gather(self, volume: NDArray[Any], which: NDArray[np.bool_]) -> NDArray[Any]:
        """Return the blocks `which` ``(Y/8, X/8)`` as leaves ``(n, 512[, 3])``."""
        b_y, b_x = np.nonzero(which)
        picked = self.view(volume)[:, b_y, :, b_x, :]  # (n, 8 z, 8 y, 8 x[, 3])
        axes = (0, 3, 2, 1, *range(4, picked.ndim))
        return picked.transpose(axes).reshape(len(b_y), LEAF**3, *volume.shape[3:])

    def origins(self, which: NDArray[np.bool_]) -> NDArray[np.int32]:
        """Return ``(n, 3)`` int32 index coordinates ``(x, y, z)`` of the blocks `which`."""
        b_y, b_x = np.nonzero(which)
        x0, y0, z0 = self.corner
        origin = np.stack([x0 + b_x * LEAF, y0 + b_y * LEAF, np.full(len(b_y), z0)], axis=1)
        return np.asarray(origin, dtype=np.int32)
