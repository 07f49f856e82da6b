"""One Z slab of the layered voxel stack: a pure function of the model, the grid and the rows.

:func:`compute_slab` returns arrays only (no files), so slabs can run in any order or in
parallel and runs can resume.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from voxel.colour import ColourAt, nearest_colour
from voxel.grid import GridSpec
from voxel.nearest import SurfaceIndex, nearest_on_surface
from voxel.winding import winding_slab

Surface = tuple[NDArray[np.float64], NDArray[np.int64]]


@dataclass(frozen=True, eq=False)
class StackModel:
    """What every slab needs: nested closed surfaces, the original surface, its colour.

    Parameters
    ----------
    surfaces : tuple of (vertices (V, 3) float64 mm, faces (F, 3) int64)
        ``[original, shell_1, ..., shell_K]``, each closed and outward; a collapsed shell
        has zero faces. A voxel's layer is how many of them contain its centre.
    surface : SurfaceIndex
        The original surface, for nearest-point queries.
    colour_at : ColourAt
        Colour of a surface point given face id and barycentric coordinates.
    colour_layers : tuple of int
        Layers (1..K+1) whose voxels take the nearest surface colour.
    sdf_half_width_mm : float, mm
        Half width of the narrow band of the outer surface's signed distance (0: none).
    """

    surfaces: tuple[Surface, ...]
    surface: SurfaceIndex
    colour_at: ColourAt
    colour_layers: tuple[int, ...] = (1,)
    sdf_half_width_mm: float = 0.0

    def __post_init__(self) -> None:
        if not self.surfaces:
            raise ValueError("surfaces must hold at least the original surface, got none")
        top = len(self.surfaces)  # K + 1
        bad = [layer for layer in self.colour_layers if not 1 <= layer <= top]
        if bad:
            raise ValueError(f"colour_layers must lie in 1..{top}, got {list(self.colour_layers)}")
        if not self.sdf_half_width_mm >= 0:
            raise ValueError(f"sdf_half_width_mm must be >= 0, got {self.sdf_half_width_mm}")

    @property
    def n_bands(self) -> int:
        """Number of shell bands ``K`` (the core is layer ``K + 1``)."""
        return len(self.surfaces) - 1


class SlabResult(NamedTuple):
    """Arrays of rows ``z_start <= z < z_stop``.

    Attributes
    ----------
    z_start, z_stop : int
        Rows covered.
    layers : (Zs, Y, X) uint8
        Layer index (0 outside, 1..K bands, K + 1 core).
    rgba : (Zs, Y, X, 4) uint8
        sRGB + alpha of the nearest surface point in the colour layers, 0 elsewhere.
    sdf : (Zs, Y, X) float32, mm
        Signed distance to the outer surface in the narrow band; ``+half_width`` outside it
        and ``-half_width`` inside it elsewhere.
    sdf_band : (Zs, Y, X) bool
        Voxels whose ``abs(sdf) < half_width``.
    n_unbalanced_rows : int
        Grid rows whose crossings did not cancel (0 for closed surfaces).
    n_nesting_violations : int
        Voxels inside a shell but outside the surface around it.
    n_nearest_queries : int
        Nearest-point queries made.
    """

    z_start: int
    z_stop: int
    layers: NDArray[np.uint8]
    rgba: NDArray[np.uint8]
    sdf: NDArray[np.float32]
    sdf_band: NDArray[np.bool_]
    n_unbalanced_rows: int
    n_nesting_violations: int
    n_nearest_queries: int


def halo_voxels(model: StackModel, grid: GridSpec) -> tuple[int, int, int]:
    """Return the halo ``(z, y, x)`` in voxels that the signed-distance band needs."""
    half_width = model.sdf_half_width_mm
    vx, vy, vz = grid.voxel_mm
    return (math.ceil(half_width / vz), math.ceil(half_width / vy), math.ceil(half_width / vx))


def compute_slab(model: StackModel, grid: GridSpec, z_start: int, z_stop: int) -> SlabResult:
    """Return layers, colours and the signed-distance band of rows ``z_start..z_stop``.

    Parameters
    ----------
    model : StackModel
        Surfaces, colour source and options.
    grid : GridSpec
        The voxel grid.
    z_start, z_stop : int
        Rows of the slab, ``0 <= z_start < z_stop <= Z``.

    Returns
    -------
    SlabResult
        Arrays of shape ``(z_stop - z_start, Y, X)``; memory is a few times the slab's.
    """
    n_z = grid.shape_zyx[0]
    if not 0 <= z_start < z_stop <= n_z:
        raise ValueError(
            f"slab rows must satisfy 0 <= z_start < z_stop <= {n_z}, got {z_start}, {z_stop}"
        )
    halo = halo_voxels(model, grid)
    low, high = max(0, z_start - halo[0]), min(n_z, z_stop + halo[0])
    vertices, faces = model.surfaces[0]
    outer = winding_slab(vertices, faces, grid, low, high)
    inside_halo = outer.winding > 0
    inside = inside_halo[z_start - low : z_stop - low]
    unbalanced = outer.n_unbalanced_rows
    layers = inside.astype(np.uint8)
    previous = inside
    violations = 0
    for shell_vertices, shell_faces in model.surfaces[1:]:
        if len(shell_faces) == 0:
            previous = np.zeros_like(inside)
            continue
        shell = winding_slab(shell_vertices, shell_faces, grid, z_start, z_stop)
        unbalanced += shell.n_unbalanced_rows
        contained = shell.winding > 0
        violations += int(np.count_nonzero(contained & ~previous))
        layers += contained
        previous = contained

    colour_mask = np.isin(layers, np.asarray(model.colour_layers, dtype=np.uint8))
    band = _band_candidates(inside_halo, z_start - low, z_stop - low, halo)
    query = colour_mask | band
    flat = np.flatnonzero(query)
    index = np.stack(np.unravel_index(flat, query.shape), axis=1)
    index[:, 0] += z_start
    nearest = nearest_on_surface(model.surface, grid.index_to_world(index))

    shape = layers.shape
    rgba = np.zeros((*shape, 4), dtype=np.uint8)
    in_colour = colour_mask.ravel()[flat]
    rgba.reshape(-1, 4)[flat[in_colour]] = nearest_colour(
        nearest._replace(
            face_ids=nearest.face_ids[in_colour],
            barycentric=nearest.barycentric[in_colour],
            distance_mm=nearest.distance_mm[in_colour],
        ),
        model.colour_at,
    )
    half_width = np.float32(model.sdf_half_width_mm)
    sdf = np.where(inside, -half_width, half_width).astype(np.float32)
    sdf_band = np.zeros(shape, dtype=bool)
    in_band = band.ravel()[flat]
    band_flat = flat[in_band]
    distance = nearest.distance_mm[in_band]
    close = distance < model.sdf_half_width_mm
    signed = np.where(inside.ravel()[band_flat], -distance, distance).astype(np.float32)
    sdf.reshape(-1)[band_flat[close]] = signed[close]
    sdf_band.reshape(-1)[band_flat[close]] = True
    return SlabResult(
        z_start, z_stop, layers, rgba, sdf, sdf_band, unbalanced, violations, len(flat)
    )


def _band_candidates(
    inside_halo: NDArray[np.bool_], start: int, stop: int, halo: tuple[int, int, int]
) -> NDArray[np.bool_]:
    """Voxels of rows ``start..stop`` within a box of ``halo`` voxels of the other side."""
    if max(halo) == 0:
        return np.zeros((stop - start, *inside_halo.shape[1:]), dtype=bool)
    size = tuple(2 * h + 1 for h in halo)
    occupied = inside_halo.view(np.uint8)
    near_inside = ndimage.maximum_filter(occupied, size=size, mode="constant", cval=0)
    near_outside = ndimage.maximum_filter(1 - occupied, size=size, mode="constant", cval=1)
    inside = inside_halo[start:stop]
    result: NDArray[np.bool_] = np.where(
        inside, near_outside[start:stop] > 0, near_inside[start:stop] > 0
    )
    return result
