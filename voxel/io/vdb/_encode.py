"""The grids of ``volume.vdb`` cut from voxel rows into 8^3 leaves and tiles (no files).

:class:`VdbEncoder` is a pure function of the rows, so the slab workers can encode their
slabs and :class:`shellvox.voxel.io.vdb._writer.VdbStackWriter` only appends the results to its
spools (the grids are described in :mod:`shellvox.voxel.io.vdb._writer`).
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel
from shellvox.voxel.colour._srgb import codes_to_linear
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io.vdb._leaves import LEAF, GridSpool

GRID_NAMES = ("density", "layer", "color", "sdf")
#: Grids whose leaves are runs of equal values (compressed by :mod:`shellvox.voxel.io._deflate`).
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
        cls,
        grid: GridSpec,
        *,
        sdf_half_width_mm: float,
        material_grid: bool,
        compression_level: int | None = None,
    ) -> VdbEncoder:
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
                spools,
                z_start + z0,
                layers[rows],
                rgb[rows],
                coloured[rows],
                sdf[rows],
                None if materials is None else materials[rows],
            )
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

        One compiled pass classifies the 8^3 blocks (rows past the top and columns past the
        grid's edge count as background); only the blocks that become leaves are gathered,
        in OpenVDB's voxel order, and converted.
        """
        hw = self._half_width
        mats = np.zeros((0, 0, 0), np.uint8) if materials is None else materials
        stats = _block_stats(layers, sdf, coloured, mats, hw)
        any_in, all_in, any_band, any_col = (stats[..., k] > 0 for k in range(4))
        low, high = stats[..., 4], stats[..., 5]
        blocks = _Blocks(z0)
        density, layer, color, level = spools[:4]
        # density and layer: the core's constant blocks are active tiles.
        density.add_tiles(blocks.origins(all_in), np.ones(int(all_in.sum()), np.float32), True)
        leaf = any_in & ~all_in
        inside = blocks.gather(layers, leaf, 0) > 0
        self._leaves(density, blocks, leaf, inside, inside)
        tile = all_in & (low == high)
        layer.add_tiles(blocks.origins(tile), low[tile].astype(np.float32), True)
        leaf = any_in & ~tile
        values = blocks.gather(layers, leaf, 0)
        self._leaves(layer, blocks, leaf, values, values > 0)
        # color: leaves wherever a colour voxel is; black ones stay active (background 0).
        leaf = any_col
        linear = codes_to_linear(blocks.gather(rgb, leaf, 0))
        on = blocks.gather(coloured, leaf, False)
        np.maximum(linear, np.float32(1e-7), out=linear, where=on[..., None])
        color.add_leaves(blocks.origins(leaf), linear, on, None, self._level)
        # sdf: inactive values are -hw inside, +hw (the background) outside.
        tile = all_in & ~any_band
        level.add_tiles(blocks.origins(tile), np.full(int(tile.sum()), -hw), False)
        leaf = any_band | (any_in & ~all_in)
        sdf_values = blocks.gather(sdf, leaf, hw)
        band, solid = np.abs(sdf_values) < hw, blocks.gather(layers, leaf, 0) > 0
        values = np.where(band, sdf_values, np.where(solid, -hw, hw))
        # Level-set values hardly compress (about 0.92): stored raw.
        level.add_leaves(blocks.origins(leaf), values.astype(np.float32), band, solid, 0)
        if materials is not None:
            # material: like layer, constant wholly non-void blocks are active tiles.
            any_on, all_on = stats[..., 6] > 0, stats[..., 7] > 0
            low, high = stats[..., 8], stats[..., 9]
            tile = all_on & (low == high)
            spools[4].add_tiles(blocks.origins(tile), low[tile].astype(np.float32), True)
            leaf = any_on & ~tile
            values = blocks.gather(materials, leaf, 0)
            self._leaves(spools[4], blocks, leaf, values, values > 0)

    def _leaves(
        self,
        spool: GridSpool,
        blocks: _Blocks,
        which: NDArray[np.bool_],
        values: NDArray[Any],
        active: NDArray[np.bool_],
    ) -> None:
        """Spool gathered leaves ``(n, 512)`` of a grid whose inactive values are its background."""
        spool.add_leaves(
            blocks.origins(which),
            values.astype(np.float32),
            active,
            None,
            self._level,
            spool.name in RUN_GRIDS,
        )


class _Blocks:
    """The 8^3 blocks of a group of rows ``(Zs <= 8, Y, X[, C])`` whose first row is `z0`.

    Block ``(b_y, b_x)`` holds voxels ``8 b_y ..`` and ``8 b_x ..``; voxels past the group's
    rows or the grid's edge are a given fill. Gathered leaves are in OpenVDB's voxel order
    ``x << 6 | y << 3 | z``.
    """

    def __init__(self, z0: int) -> None:
        self.z0 = z0

    def gather(self, volume: NDArray[Any], which: NDArray[np.bool_], fill: Any) -> NDArray[Any]:
        """Return the blocks `which` ``(Y/8, X/8)`` of `volume` as leaves ``(n, 512[, C])``."""
        b_y, b_x = np.nonzero(which)
        shape = (len(b_y), LEAF**3, *volume.shape[3:])
        out = np.empty(shape, dtype=volume.dtype)
        n_c = volume.shape[3] if volume.ndim == 4 else 1
        flat = volume.reshape(*volume.shape[:3], n_c)
        _gather(flat, b_y, b_x, volume.dtype.type(fill), out.reshape(len(b_y), LEAF**3, n_c))
        return out

    def origins(self, which: NDArray[np.bool_]) -> NDArray[np.int32]:
        """Return ``(n, 3)`` int32 index coordinates ``(x, y, z)`` of the blocks `which`."""
        b_y, b_x = np.nonzero(which)
        origin = np.stack([b_x * LEAF, b_y * LEAF, np.full(len(b_y), self.z0)], axis=1)
        return np.asarray(origin, dtype=np.int32)


@kernel
def _block_stats(
    layers: NDArray[np.uint8],
    sdf: NDArray[np.float32],
    coloured: NDArray[np.bool_],
    materials: NDArray[np.uint8],
    hw: np.float32,
) -> NDArray[np.int32]:
    """Classify the 8^3 blocks of rows ``(Zs <= 8, Y, X)`` in one pass.

    Returns ``(ceil(Y/8), ceil(X/8), 10)`` int32: any inside, all inside, any in the
    distance band, any coloured, lowest and highest layer, then (with materials, else 0)
    any non-void material, all non-void, lowest and highest material. Voxels past the
    rows or the edge count as layer 0, material 0, outside the band, not coloured.
    Each block row is first reduced over its voxel rows into columns (contiguous loops
    that LLVM vectorises), then the columns over each block's 8.
    """
    n_z, n_y, n_x = layers.shape
    b_y, b_x = -(-n_y // LEAF), -(-n_x // LEAF)
    has_materials = materials.shape[0] > 0
    stats = np.zeros((b_y, b_x, 10), np.int32)
    n_in, low, high = np.empty(n_x, np.int32), np.empty(n_x, np.uint8), np.empty(n_x, np.uint8)
    band, colour = np.empty(n_x, np.uint8), np.empty(n_x, np.uint8)
    n_on, m_low = np.empty(n_x, np.int32), np.empty(n_x, np.uint8)
    m_high = np.empty(n_x, np.uint8)
    for j in range(b_y):
        n_in[:], low[:], high[:], band[:], colour[:] = 0, 255, 0, 0, 0
        n_on[:], m_low[:], m_high[:] = 0, 255, 0
        y_end = min(n_y, (j + 1) * LEAF)
        for z in range(n_z):
            for y in range(j * LEAF, y_end):
                layer_row, sdf_row, colour_row = layers[z, y], sdf[z, y], coloured[z, y]
                for x in range(n_x):
                    value = layer_row[x]
                    n_in[x] += np.int32(value > 0)
                    low[x] = min(low[x], value)
                    high[x] = max(high[x], value)
                    band[x] |= np.uint8(abs(sdf_row[x]) < hw)
                    colour[x] |= np.uint8(colour_row[x])
                if has_materials:
                    material_row = materials[z, y]
                    for x in range(n_x):
                        material = material_row[x]
                        n_on[x] += np.int32(material > 0)
                        m_low[x] = min(m_low[x], material)
                        m_high[x] = max(m_high[x], material)
        for i in range(b_x):
            x_end = min(n_x, (i + 1) * LEAF)
            whole = n_z == LEAF and y_end - j * LEAF == LEAF and x_end - i * LEAF == LEAF
            count, lo, hi, in_band, any_colour = 0, 255, 0, 0, 0
            count_on, lo_on, hi_on = 0, 255, 0
            for x in range(i * LEAF, x_end):
                count += n_in[x]
                lo, hi = min(lo, low[x]), max(hi, high[x])
                in_band |= band[x]
                any_colour |= colour[x]
                count_on += n_on[x]
                lo_on, hi_on = min(lo_on, m_low[x]), max(hi_on, m_high[x])
            stats[j, i, 0] = count > 0
            stats[j, i, 1] = whole and count == LEAF**3
            stats[j, i, 2] = in_band
            stats[j, i, 3] = any_colour
            stats[j, i, 4] = lo if whole else 0  # a block past the edge holds layer 0
            stats[j, i, 5] = hi
            if has_materials:
                stats[j, i, 6] = count_on > 0
                stats[j, i, 7] = whole and count_on == LEAF**3
                stats[j, i, 8] = lo_on if whole else 0
                stats[j, i, 9] = hi_on
    return stats


@kernel
def _gather(
    volume: NDArray[Any],
    b_y: NDArray[np.int64],
    b_x: NDArray[np.int64],
    fill: Any,
    out: NDArray[Any],
) -> None:
    """Copy blocks ``(b_y, b_x)`` of ``volume (Zs, Y, X, C)`` to ``out (n, 512, C)``.

    Voxel order ``x << 6 | y << 3 | z``; voxels past the rows or the edge are `fill`.
    """
    n_z, n_y, n_x, n_c = volume.shape
    for n in range(len(b_y)):
        y0, x0 = b_y[n] * LEAF, b_x[n] * LEAF
        for dx in range(LEAF):
            for dy in range(LEAF):
                for dz in range(LEAF):
                    at = dx << 6 | dy << 3 | dz
                    x, y = x0 + dx, y0 + dy
                    if dz < n_z and y < n_y and x < n_x:
                        for c in range(n_c):
                            out[n, at, c] = volume[dz, y, x, c]
                    else:
                        for c in range(n_c):
                            out[n, at, c] = fill
