"""Compiled per-voxel loops of the separation and the halftones (numba).

These loops run once per voxel of a slab, where numpy would need several passes over
``(N, 8, M)`` temporaries (about 1 M colour voxels/s against 10 to 20 M here). Each
kernel is written as plain Python over arrays and compiled by
:func:`shellvox.voxel._compiled.kernel`; the blue-noise kernel and ``proportions_kernel`` share
the interpolation, so a voxel's material follows from exactly the proportions
``Separation.proportions`` reports.

Callers: :mod:`shellvox.voxel.colour._separation` (``Separation.proportions``) and
:mod:`shellvox.voxel.colour._materials` (``materials_for_slab``). Nothing here checks its input.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

#: Lou and Stucki's 3D error filter: ``(dz, dy, dx, weight * 21)`` of the 12 forward
#: neighbours of a voxel in raster order (z, then y, then x), weights 4/21 and 1/21.
#: The neighbour set is that of VoxelFuse's ``dither`` (cdbrauer/VoxelFuse,
#: voxel_model.py), which cites Q. Lou and P. Stucki, "Fundamentals of 3D halftoning",
#: EP'98 / RIDT'98, LNCS 1375 (1998).
DIFFUSION_NEIGHBOURS = np.array(
    [
        (0, 0, 1, 4), (0, 0, 2, 1), (0, 1, 0, 4), (0, 2, 0, 1), (0, 1, 1, 1), (0, 1, -1, 1),
        (1, -1, 0, 1), (1, 0, -1, 1), (1, 1, 0, 1), (1, 0, 1, 1), (1, 0, 0, 4), (2, 0, 0, 1),
    ],
    dtype=np.int64,
)  # fmt: skip


class BlueNoisePlan(NamedTuple):
    """What :data:`threshold_slab_kernel` needs besides the slab's voxels.

    Attributes
    ----------
    layer_material : (256,) uint8
        The material of every non-colour layer.
    is_colour : (256,) bool
        Layers whose voxels take a colour.
    cell, weight : (256,) int64, (256,) float32
        The separation's lattice cell and weight of every sRGB code.
    table : (G, G, G, P) float32
        The opaque proportions at the lattice nodes.
    has_clear : bool
        The last column is clear (its share is ``1 - alpha``).
    tile : (S0, S1, S2) float32
        The blue-noise thresholds.
    column_material : (M,) uint8
        The material of every column (separation order, clear last).
    """

    layer_material: NDArray[np.uint8]
    is_colour: NDArray[np.bool_]
    cell: NDArray[np.int64]
    weight: NDArray[np.float32]
    table: NDArray[np.float32]
    has_clear: bool
    tile: NDArray[np.float32]
    column_material: NDArray[np.uint8]


class _Lattice(NamedTuple):
    """The separation's table as :func:`_opaque_mix_py` reads it."""

    cell: NDArray[np.int64]
    weight: NDArray[np.float32]
    flat_table: NDArray[np.float32]  # the (G, G, G, P) table raveled
    n_nodes: int  # G


class _Scratch(NamedTuple):
    """Arrays :func:`_opaque_mix_py` fills: corner weights and offsets, and the mix."""

    corner_weight: NDArray[np.float32]  # (8,)
    corner_offset: NDArray[np.int64]  # (8,)
    mix: NDArray[np.float32]  # (P,)


def _jit(function: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``function`` with :func:`~shellvox.voxel._compiled.kernel` (the Python one stays)."""
    compiled: Callable[..., Any] = kernel(function)
    return compiled


def _opaque_mix_py(r, g, b, lattice, scratch):  # type: ignore[no-untyped-def]
    """Trilinear interpolation of the opaque proportions of sRGB codes ``r, g, b``.

    Into ``scratch.mix``; ``scratch.corner_weight`` and ``scratch.corner_offset`` are
    scratch. Corners go in ``(dr, dg, db)`` order and each proportion is summed in a
    register (no store per term).
    """
    cell, weight, flat_table, n_nodes = lattice
    corner_weight, corner_offset, out = scratch
    n_opaque = out.shape[0]
    one = np.float32(1.0)
    wr = weight[r]
    wg = weight[g]
    wb = weight[b]
    base = ((cell[r] * n_nodes + cell[g]) * n_nodes + cell[b]) * n_opaque
    corner = 0
    for dr in range(2):
        fr = wr if dr else one - wr
        for dg in range(2):
            fg = wg if dg else one - wg
            for db in range(2):
                fb = wb if db else one - wb
                corner_weight[corner] = fr * fg * fb
                corner_offset[corner] = base + ((dr * n_nodes + dg) * n_nodes + db) * n_opaque
                corner += 1
    for k in range(n_opaque):
        total = np.float32(0.0)
        for corner in range(8):
            total += corner_weight[corner] * flat_table[corner_offset[corner] + k]
        out[k] = total


_opaque_mix = _jit(_opaque_mix_py)


def _proportions_py(rgba, cell, weight, table, has_clear, out):  # type: ignore[no-untyped-def]
    """Fill ``out`` (N, M) float32 with the proportions of ``rgba`` (N, 4) uint8."""
    n_opaque = table.shape[3]
    lattice = _Lattice(cell, weight, table.reshape(-1), table.shape[0])
    mix = np.empty(n_opaque, dtype=np.float32)
    scratch = _Scratch(np.empty(8, dtype=np.float32), np.empty(8, dtype=np.int64), mix)
    for i in range(rgba.shape[0]):
        _opaque_mix(rgba[i, 0], rgba[i, 1], rgba[i, 2], lattice, scratch)
        if has_clear:
            alpha = np.float32(rgba[i, 3]) / np.float32(255.0)
            for k in range(n_opaque):
                out[i, k] = mix[k] * alpha
            out[i, n_opaque] = np.float32(1.0) - alpha
        else:
            for k in range(n_opaque):
                out[i, k] = mix[k]


proportions_kernel = _jit(_proportions_py)


def _threshold_slab_py(layers, rgba, z_start, plan, out):  # type: ignore[no-untyped-def]
    """Fill ``out`` (Zs, Y, X) uint8 with one material per voxel (blue-noise threshold).

    ``plan`` is a :class:`BlueNoisePlan`. Non-colour layers take
    ``layer_material[layer]``. A colour voxel's threshold is
    ``tile[(z_start + z) % s, y % s, x % s]``; its material is the column whose
    cumulative-proportion interval holds it (columns in separation order, clear last).
    """
    layer_material, is_colour, has_clear = plan.layer_material, plan.is_colour, plan.has_clear
    tile, column_material, table = plan.tile, plan.column_material, plan.table
    n_opaque = table.shape[3]
    lattice = _Lattice(plan.cell, plan.weight, table.reshape(-1), table.shape[0])
    s0, s1, s2 = tile.shape
    mix = np.empty(n_opaque, dtype=np.float32)
    scratch = _Scratch(np.empty(8, dtype=np.float32), np.empty(8, dtype=np.int64), mix)
    for z in range(layers.shape[0]):
        tz = (z_start + z) % s0
        for y in range(layers.shape[1]):
            ty = y % s1
            for x in range(layers.shape[2]):
                layer = layers[z, y, x]
                if not is_colour[layer]:
                    out[z, y, x] = layer_material[layer]
                    continue
                _opaque_mix(rgba[z, y, x, 0], rgba[z, y, x, 1], rgba[z, y, x, 2], lattice, scratch)
                alpha = np.float32(1.0)
                if has_clear:
                    alpha = np.float32(rgba[z, y, x, 3]) / np.float32(255.0)
                threshold = tile[tz, ty, x % s2]
                chosen = n_opaque if has_clear else n_opaque - 1
                total = np.float32(0.0)
                for k in range(n_opaque):
                    total += mix[k] * alpha
                    if threshold < total:
                        chosen = k
                        break
                out[z, y, x] = column_material[chosen]


threshold_slab_kernel = _jit(_threshold_slab_py)


def _diffuse_py(zyx, proportions, mask, error, neighbours, chosen):  # type: ignore[no-untyped-def]
    """Vector error diffusion over the colour voxels ``zyx`` (N, 3), in raster order.

    ``error`` (3, Y, X, M) float32 is a ring of planes (slot ``z % 3``) holding the error
    already sent to planes ``z, z + 1, z + 2``; on return the slots of planes ``Zs`` and
    ``Zs + 1`` hold the error sent beyond the slab. A voxel takes the column of largest
    ``proportion + error``; the difference to that choice goes to its forward neighbours
    in proportion to their weights, over the neighbours that can take it (in the grid's
    y, x range and, within the slab, colour voxels; planes beyond the slab all count).
    """
    n_slab, n_y, n_x = mask.shape
    n_columns = proportions.shape[1]
    value = np.empty(n_columns, dtype=np.float32)
    taken = np.empty(neighbours.shape[0], dtype=neighbours.dtype)
    plane = 0
    for i in range(zyx.shape[0]):
        z = zyx[i, 0]
        y = zyx[i, 1]
        x = zyx[i, 2]
        while plane < z:
            error[plane % 3] = 0
            plane += 1
        best = 0
        for k in range(n_columns):
            value[k] = proportions[i, k] + error[z % 3, y, x, k]
            if value[k] > value[best]:
                best = k
        chosen[i] = best
        value[best] -= np.float32(1.0)
        total = 0
        for j in range(neighbours.shape[0]):  # the weights of the neighbours that take it
            nz = z + neighbours[j, 0]
            ny = y + neighbours[j, 1]
            nx = x + neighbours[j, 2]
            inside = 0 <= ny < n_y and 0 <= nx < n_x
            taken[j] = neighbours[j, 3] if inside and (nz >= n_slab or mask[nz, ny, nx]) else 0
            total += taken[j]
        if total == 0:
            continue
        for j in range(neighbours.shape[0]):
            if taken[j] == 0:
                continue
            share = np.float32(taken[j] / total)
            nz = z + neighbours[j, 0]
            for k in range(n_columns):
                error[nz % 3, y + neighbours[j, 1], x + neighbours[j, 2], k] += value[k] * share
    while plane < n_slab:
        error[plane % 3] = 0
        plane += 1


diffuse_kernel = _jit(_diffuse_py)
