"""One material per voxel: the per-slab step after the layers and colours.

:func:`materials_for_slab` turns a slab's layers and nearest-surface colours into
material indices (uint8, 0 the void) following a :class:`MaterialPlan`:

- outside (layer 0): the void, index 0;
- colour layers: the separation's proportions of the voxel's sRGBA, halftoned to one
  material per voxel;
- the core layer ``K + 1`` (unless it is a colour layer): the core material;
- every other layer (the backing bands): the backing material.

Halftones
---------
``"blue-noise"`` (default): a voxel's threshold is the blue-noise tile's value at its
*global* index, ``tile[(z_start + z) % s, y % s, x % s]``
(:mod:`shellvox.voxel.colour._blue_noise`), and its material is the column whose
cumulative-proportion interval ``[c_{k-1}, c_k)`` holds the threshold (columns in the separation's
order, clear last). The result is a pure function of ``(z_start, layers, rgba, plan)``: any split
into slabs, in any order, gives the same materials.

``"error-diffusion"``: 3D vector error diffusion over the colour voxels in raster order
with Lou and Stucki's 12-neighbour filter
(:data:`shellvox.voxel.colour._material_kernels.DIFFUSION_NEIGHBOURS`);
a voxel takes the column of largest proportion-plus-error. It is sequential: slabs
must run in order, each passing :attr:`MaterialSlab.carry` (the error sent to the next
two planes) to the next. The result still depends on the split, slightly: the error
sent across a slab boundary counts every neighbour beyond it as a colour voxel, and
what lands on a non-colour voxel there is lost. Like any error diffusion it starts
with a transient: the first voxels of a region hold no error yet, so 16^3 windows that
touch a region's first rows can miss the proportions by a few percent (2.4 % seen in
the tests), where windows a few voxels in are within 1 %.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._blue_noise import DEFAULT_TILE, blue_noise_tile
from shellvox.voxel.colour._material_kernels import (
    DIFFUSION_NEIGHBOURS,
    BlueNoisePlan,
    diffuse_kernel,
    threshold_slab_kernel,
)
from shellvox.voxel.colour._separation import Separation

Halftone = Literal["blue-noise", "error-diffusion"]
HALFTONES: tuple[Halftone, ...] = ("blue-noise", "error-diffusion")


@dataclass(frozen=True, eq=False)
class MaterialPlan:
    """How a slab's voxels get their materials; built once, picklable.

    Parameters
    ----------
    separation : Separation
        Colour to proportions of the colour materials.
    column_materials : tuple of int
        Material index (1..255) of each separation column, in column order.
    colour_layers : tuple of int
        Layers (1..``core_layer``) whose voxels are halftoned.
    core_layer : int
        Layer index of the core, ``K + 1``.
    backing_material, core_material : int
        Material index of the backing bands and of the core.
    halftone : {"blue-noise", "error-diffusion"}
        See the module.
    seed : int
        Seed of the blue-noise tile.
    tile_size : int
        Edge of the blue-noise tile in voxels (see :mod:`shellvox.voxel.colour._blue_noise`).
    """

    separation: Separation
    column_materials: tuple[int, ...]
    colour_layers: tuple[int, ...]
    core_layer: int
    backing_material: int
    core_material: int
    halftone: Halftone = "blue-noise"
    seed: int = 0
    tile_size: int = DEFAULT_TILE
    thresholds: NDArray[np.float32] = field(init=False, repr=False)
    layer_material: NDArray[np.uint8] = field(init=False, repr=False)
    is_colour: NDArray[np.bool_] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.halftone not in HALFTONES:
            raise ValueError(f"halftone must be one of {HALFTONES}, got {self.halftone!r}")
        if len(self.column_materials) != self.separation.n_columns:
            raise ValueError(
                f"column_materials must give {self.separation.n_columns} indices "
                f"(one per separation column {self.separation.roles}), "
                f"got {self.column_materials}"
            )
        indices = (*self.column_materials, self.backing_material, self.core_material)
        if not all(1 <= index <= 255 for index in indices):
            raise ValueError(f"material indices must lie in 1..255 (0 is the void), got {indices}")
        if not 1 <= self.core_layer <= 255:
            raise ValueError(f"core_layer must lie in 1..255, got {self.core_layer}")
        if not self.colour_layers or not all(
            1 <= layer <= self.core_layer for layer in self.colour_layers
        ):
            raise ValueError(
                f"colour_layers must lie in 1..{self.core_layer}, got {self.colour_layers}"
            )
        layer_material = np.zeros(256, dtype=np.uint8)
        layer_material[1 : self.core_layer] = self.backing_material
        layer_material[self.core_layer] = self.core_material
        is_colour = np.zeros(256, dtype=bool)
        is_colour[list(self.colour_layers)] = True
        layer_material[is_colour] = 0
        object.__setattr__(self, "layer_material", layer_material)
        object.__setattr__(self, "is_colour", is_colour)
        object.__setattr__(self, "thresholds", blue_noise_tile(self.tile_size, seed=self.seed))


class MaterialSlab(NamedTuple):
    """Materials of rows ``z_start .. z_start + Zs``.

    Attributes
    ----------
    materials : (Zs, Y, X) uint8
        Material index per voxel (0 the void).
    carry : (2, Y, X, M) float32 or None
        Error diffusion only: the error sent to the next slab's first two planes (pass
        it as ``carry`` to the next slab). None for the blue-noise halftone.
    """

    materials: NDArray[np.uint8]
    carry: NDArray[np.float32] | None


def materials_for_slab(
    layers: NDArray[np.uint8],
    rgba: NDArray[np.uint8],
    z_start: int,
    plan: MaterialPlan,
    *,
    carry: NDArray[np.float32] | None = None,
) -> MaterialSlab:
    """Return one material per voxel of a slab (see the module for the rules).

    Parameters
    ----------
    layers : (Zs, Y, X) uint8
        Layer index (0 outside, 1..K bands, K + 1 core), as ``compute_slab`` returns.
    rgba : (Zs, Y, X, 4) uint8
        sRGB + alpha of the nearest surface point (read in colour layers only).
    z_start : int
        Global index of the slab's first row (the blue-noise tile is indexed globally).
    plan : MaterialPlan
        Separation, materials and halftone.
    carry : (2, Y, X, M) float32 or None
        Error diffusion only: the previous slab's :attr:`MaterialSlab.carry` (None for
        the first slab). Must be None for the blue-noise halftone.

    Returns
    -------
    MaterialSlab
        Materials ``(Zs, Y, X) uint8`` and the error carry.
    """
    layers = np.asarray(layers)
    rgba = np.asarray(rgba)
    if layers.ndim != 3 or layers.dtype != np.uint8:
        raise ValueError(f"layers must be (Zs, Y, X) uint8, got {layers.shape} {layers.dtype}")
    if rgba.shape != (*layers.shape, 4) or rgba.dtype != np.uint8:
        raise ValueError(f"rgba must be {(*layers.shape, 4)} uint8, got {rgba.shape} {rgba.dtype}")
    if z_start < 0:
        raise ValueError(f"z_start must be >= 0, got {z_start}")
    top = int(layers.max(initial=0))
    if top > plan.core_layer:
        raise ValueError(f"layers must lie in 0..{plan.core_layer} (the core), got {top}")
    layers = np.ascontiguousarray(layers)
    rgba = np.ascontiguousarray(rgba)
    if plan.halftone == "blue-noise":
        if carry is not None:
            raise ValueError("carry is for the error-diffusion halftone only, got an array")
        out = np.empty(layers.shape, dtype=np.uint8)
        sep = plan.separation
        blue_noise = BlueNoisePlan(
            plan.layer_material,
            plan.is_colour,
            sep.cell_index,
            sep.cell_weight,
            sep.table,
            sep.has_clear,
            plan.thresholds,
            np.asarray(plan.column_materials, dtype=np.uint8),
        )
        threshold_slab_kernel(layers, rgba, z_start, blue_noise, out)
        return MaterialSlab(out, None)
    return _diffused(layers, rgba, plan, carry)


def _diffused(
    layers: NDArray[np.uint8],
    rgba: NDArray[np.uint8],
    plan: MaterialPlan,
    carry: NDArray[np.float32] | None,
) -> MaterialSlab:
    """Materials by 3D error diffusion; returns the error carry for the next slab."""
    n_columns = plan.separation.n_columns
    plane_shape = (layers.shape[1], layers.shape[2], n_columns)
    error = np.zeros((3, *plane_shape), dtype=np.float32)
    if carry is not None:
        if carry.shape != (2, *plane_shape) or carry.dtype != np.float32:
            raise ValueError(
                f"carry must be {(2, *plane_shape)} float32, got {carry.shape} {carry.dtype}"
            )
        error[:2] = carry
    out = plan.layer_material[layers]
    mask = plan.is_colour[layers]
    zyx = np.argwhere(mask)
    proportions = plan.separation.proportions(rgba[mask])
    chosen = np.empty(len(zyx), dtype=np.uint8)
    diffuse_kernel(zyx, proportions, mask, error, DIFFUSION_NEIGHBOURS, chosen)
    out[mask] = np.asarray(plan.column_materials, dtype=np.uint8)[chosen]
    n_slab = layers.shape[0]
    next_carry = np.stack([error[n_slab % 3], error[(n_slab + 1) % 3]])
    return MaterialSlab(out, next_carry)
