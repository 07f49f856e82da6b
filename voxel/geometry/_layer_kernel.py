"""Compiled per-voxel pass of a slab: layers, signed-distance band and colour voxels.

One pass over the slab turns the inside test and the nearest faces within reach
(:mod:`shellvox.voxel.geometry._distance_scan`) into the layer of every voxel, the narrow band of
the signed distance, and the voxels that take a surface colour; a numpy version needed a dozen
passes over slab-sized temporaries. Callers: :func:`shellvox.voxel.slab.compute_slab`. Nothing
here checks its input.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel


class LayerInputs(NamedTuple):
    """What :func:`assign_layers` reads of a slab.

    Attributes
    ----------
    inside : (Zs, Y, X) bool
        Voxel centres inside the outer surface.
    squared : (Zs, Y, X) float64, mm^2
        Squared distance to the nearest face where ``face >= 0``.
    face : (Zs, Y, X) int32
        Nearest face, -1 where it is farther than the reach.
    depth : (K, F) float64, mm
        Cumulative depth of each band per face (used when ``by_distance``).
    by_distance : bool
        Layers from the distance (band ``k`` where ``D_{k-1}(f) <= d < D_k(f)``; ``K + 1``
        beyond the reach); otherwise ``layers`` already holds them and is kept.
    half_width : float, mm
        Half width of the signed-distance band.
    is_colour : (256,) bool
        Layers whose voxels take a colour.
    """

    inside: NDArray[np.bool_]
    squared: NDArray[np.float64]
    face: NDArray[np.int32]
    depth: NDArray[np.float64]
    by_distance: bool
    half_width: float
    is_colour: NDArray[np.bool_]


class LayerOutputs(NamedTuple):
    """What :func:`assign_layers` fills in place.

    Attributes
    ----------
    layers : (Zs, Y, X) uint8
        Output (or input, see ``LayerInputs.by_distance``).
    sdf : (Zs, Y, X) float32, mm
        Output: signed distance in the band, ``-+half_width`` inside / outside elsewhere.
    sdf_band : (Zs, Y, X) bool
        Output: ``|sdf| < half_width``.
    counts : (256,) int64
        Output: voxels per layer (added to).
    """

    layers: NDArray[np.uint8]
    sdf: NDArray[np.float32]
    sdf_band: NDArray[np.bool_]
    counts: NDArray[np.int64]


@kernel
def assign_layers(given: LayerInputs, out: LayerOutputs) -> tuple[int, int, int]:
    """Fill ``layers`` (by distance), ``sdf`` and ``sdf_band`` of a slab in place.

    Parameters
    ----------
    given : LayerInputs
        The inside test, the nearest faces within reach and the layers' rule.
    out : LayerOutputs
        The slab's layers, signed distances, band and counts per layer, filled in place.

    Returns
    -------
    n_colour : int
        Voxels in a colour layer.
    n_unreached : int
        Of those, voxels without a nearest face (beyond the reach).
    n_reached : int
        Voxels with a nearest face.
    """
    inside, squared, face, depth, by_distance, half_width, is_colour = given
    layers, sdf, sdf_band, counts = out
    n_z, n_y, n_x = inside.shape
    n_bands = depth.shape[0]
    core = np.uint8(n_bands + 1)
    plus = np.float32(half_width)
    minus = np.float32(-half_width)
    n_colour = 0
    n_unreached = 0
    n_reached = 0
    for k in range(n_z):
        for j in range(n_y):
            row_inside = inside[k, j]
            row_squared = squared[k, j]
            row_face = face[k, j]
            row_layers = layers[k, j]
            row_sdf = sdf[k, j]
            row_band = sdf_band[k, j]
            for i in range(n_x):
                f = row_face[i]
                is_in = row_inside[i]
                layer = row_layers[i]
                value = minus if is_in else plus
                band = False
                distance = math.inf
                if f >= 0:
                    distance = math.sqrt(row_squared[i])
                    n_reached += 1
                if by_distance:
                    if not is_in:
                        layer = np.uint8(0)
                    elif f < 0:
                        layer = core
                    else:
                        layer = np.uint8(1)
                        for b in range(n_bands):
                            if distance >= depth[b, f]:
                                layer += np.uint8(1)
                if distance < half_width:
                    value = np.float32(-distance if is_in else distance)
                    band = True
                if by_distance:
                    row_layers[i] = layer
                row_sdf[i] = value
                row_band[i] = band
                counts[layer] += 1
                if is_colour[layer]:
                    n_colour += 1
                    if f < 0:
                        n_unreached += 1
    return n_colour, n_unreached, n_reached


@kernel
def colour_voxels(
    layers: NDArray[np.uint8], is_colour: NDArray[np.bool_], count: int
) -> NDArray[np.int64]:
    """Return the flat indices ``(count,) int64`` of the voxels in a colour layer."""
    flat = layers.reshape(-1)
    out = np.empty(count, dtype=np.int64)
    n = 0
    for index in range(flat.size):
        if is_colour[flat[index]]:
            out[n] = index
            n += 1
    return out[:n]


@kernel
def layer_material_counts(
    layers: NDArray[np.uint8], materials: NDArray[np.uint8], n_layers: int
) -> NDArray[np.int64]:
    """Return voxels per layer and material ``(n_layers, 256) int64`` (one pass)."""
    counts = np.zeros((n_layers, 256), dtype=np.int64)
    flat_layers = layers.reshape(-1)
    flat_materials = materials.reshape(-1)
    for index in range(flat_layers.size):
        counts[flat_layers[index], flat_materials[index]] += 1
    return counts
