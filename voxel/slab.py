"""One Z slab of the layered voxel stack: a pure function of the model, the grid and the rows.

:func:`compute_slab` returns arrays only (no files), so slabs can run in any order or in
parallel and runs can resume.

Two layer realisations:

* **distance** (``StackModel.depth_mm`` given): a voxel inside the outer surface lies in
  band ``k`` when ``D_{k-1}(f) <= d < D_k(f)``, with ``d`` its exact distance to the
  original surface and ``f`` the face of its nearest point; this is the ideal offset
  (rounded at reflex features, collapsing in thin walls) sampled exactly at the voxel
  centres. Block bounds (:mod:`voxel.blocks`) settle whole blocks that lie in one band
  or in the core; only voxels in blocks that straddle a band limit, that take colour or
  that reach into the signed-distance band are queried one by one.
* **shells** (``depth_mm`` None): a voxel's layer is how many of the nested closed
  surfaces ``surfaces`` contain its centre (exact winding numbers).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from voxel.blocks import COARSE, block_bounds, fine_block_size
from voxel.colour import ColourAt, nearest_colour
from voxel.grid import GridSpec
from voxel.nearest import SurfaceIndex, nearest_faces, on_faces
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
    depth_mm : (K, F) float64, mm, optional
        Cumulative depth ``D_k(f)`` of each band per original face (non-decreasing in
        ``k``). Given: layers by distance, and ``surfaces`` needs only the original.
    """

    surfaces: tuple[Surface, ...]
    surface: SurfaceIndex
    colour_at: ColourAt
    colour_layers: tuple[int, ...] = (1,)
    sdf_half_width_mm: float = 0.0
    depth_mm: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        if not self.surfaces:
            raise ValueError("surfaces must hold at least the original surface, got none")
        if self.depth_mm is not None:
            depth = self.depth_mm
            n_faces = len(self.surfaces[0][1])
            if depth.ndim != 2 or depth.shape[1] != n_faces or depth.shape[0] < 1:
                raise ValueError(f"depth_mm must be (K, {n_faces}), got shape {depth.shape}")
            if not (np.all(np.isfinite(depth)) and np.all(depth > 0)) or np.any(
                np.diff(depth, axis=0) < 0
            ):
                raise ValueError("depth_mm must be positive, finite and non-decreasing in k")
        top = self.n_bands + 1
        bad = [layer for layer in self.colour_layers if not 1 <= layer <= top]
        if bad:
            raise ValueError(f"colour_layers must lie in 1..{top}, got {list(self.colour_layers)}")
        if not self.sdf_half_width_mm >= 0:
            raise ValueError(f"sdf_half_width_mm must be >= 0, got {self.sdf_half_width_mm}")

    @property
    def n_bands(self) -> int:
        """Number of shell bands ``K`` (the core is layer ``K + 1``)."""
        if self.depth_mm is not None:
            return int(self.depth_mm.shape[0])
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
        Nearest-point queries made (one per queried voxel).
    n_block_queries : int
        Distance queries of block centres (:mod:`voxel.blocks`).
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
    n_block_queries: int


def block_reach_mm(model: StackModel) -> float:
    """Return the distance (mm) within which voxels may need a query (0: none by distance)."""
    if model.depth_mm is not None:
        return max(float(model.depth_mm.max()), model.sdf_half_width_mm)
    return model.sdf_half_width_mm


def aligned_rows(model: StackModel, grid: GridSpec) -> int:
    """Return the rows of a coarse block: slabs of a multiple of them waste no block queries."""
    reach = block_reach_mm(model)
    return fine_block_size(grid, reach)[0] * COARSE if reach > 0 else 1


def compute_slab(model: StackModel, grid: GridSpec, z_start: int, z_stop: int) -> SlabResult:
    """Return layers, colours and the signed-distance band of rows ``z_start..z_stop``.

    Needs no halo: inside tests run along x rows and distance bounds come from block
    queries (:mod:`voxel.blocks`), so a slab reads nothing beyond its own rows and any
    split into slabs gives the same arrays.

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
    vertices, faces = model.surfaces[0]
    outer = winding_slab(vertices, faces, grid, z_start, z_stop)
    unbalanced = outer.n_unbalanced_rows
    inside = outer.winding > 0
    del outer
    shape = (inside.shape[0], inside.shape[1], inside.shape[2])
    colour_values = np.asarray(model.colour_layers, dtype=np.uint8)
    half_width = model.sdf_half_width_mm
    violations = n_block = 0
    if model.depth_mm is None:
        layers, unbalanced_shells, violations = _shell_layers(model, grid, inside, z_start)
        unbalanced += unbalanced_shells
        query = np.isin(layers, colour_values)
        if half_width > 0:
            bounds = block_bounds(model.surface, grid, z_start, z_stop, half_width)
            query |= bounds.expand(bounds.lower_mm < half_width, shape)
            n_block = bounds.n_queries
    else:
        layers, query, n_block = _distance_plan(model, grid, inside, z_start, z_stop)
    flat = np.flatnonzero(query)
    del query
    index = np.stack(np.unravel_index(flat, shape), axis=1)
    index[:, 0] += z_start
    points = grid.index_to_world(index)
    del index
    face_ids, distance_mm = nearest_faces(model.surface, points)
    queried_inside = inside.ravel()[flat]
    if model.depth_mm is not None:
        # band k where D_{k-1}(f) <= d < D_k(f), f the nearest face
        depth = model.depth_mm[:, face_ids[queried_inside]]
        deeper = (distance_mm[queried_inside][None, :] >= depth).sum(axis=0)
        layers.reshape(-1)[flat[queried_inside]] = (1 + deeper).astype(np.uint8)

    # barycentric coordinates only where a colour is needed
    in_colour = np.isin(layers.ravel()[flat], colour_values)
    rgba = np.zeros((*shape, 4), dtype=np.uint8)
    nearest = on_faces(model.surface, points[in_colour], face_ids[in_colour])
    del points
    rgba.reshape(-1, 4)[flat[in_colour]] = nearest_colour(nearest, model.colour_at)
    half = np.float32(half_width)
    sdf = np.where(inside, -half, half).astype(np.float32)
    sdf_band = np.zeros(shape, dtype=bool)
    close = distance_mm < half_width
    band_flat = flat[close]
    distance = distance_mm[close]
    signed = np.where(queried_inside[close], -distance, distance)
    sdf.reshape(-1)[band_flat] = signed.astype(np.float32)
    sdf_band.reshape(-1)[band_flat] = True
    return SlabResult(
        z_start, z_stop, layers, rgba, sdf, sdf_band, unbalanced, violations, len(flat), n_block
    )


def _distance_plan(
    model: StackModel, grid: GridSpec, inside: NDArray[np.bool_], z_start: int, z_stop: int
) -> tuple[NDArray[np.uint8], NDArray[np.bool_], int]:
    """Layers known from block bounds, and the voxels that need their own query.

    A block whose distance bounds ``[lo, hi]`` fit between two band limits for every face
    (``lo >= max_f D_{b-1}(f)`` and ``hi < min_f D_b(f)``) lies wholly in band ``b``; its
    inside voxels need no query unless ``b`` takes colour or the block reaches into the
    signed-distance band. Returns layers ``(Zs, Y, X) uint8`` (0 outside, the block's
    band inside where known, 0 where queried), the query mask and the block queries made.
    """
    assert model.depth_mm is not None
    shape = (inside.shape[0], inside.shape[1], inside.shape[2])
    half_width = model.sdf_half_width_mm
    deepest = model.depth_mm.max(axis=1)
    shallowest = model.depth_mm.min(axis=1)
    bounds = block_bounds(model.surface, grid, z_start, z_stop, block_reach_mm(model))
    lo, hi = bounds.lower_mm, bounds.upper_mm
    band_lo = 1 + (lo[..., None] >= deepest).sum(axis=-1)
    band_hi = 1 + (hi[..., None] >= shallowest).sum(axis=-1)
    code = np.where(band_lo == band_hi, band_lo, 0).astype(np.uint8)
    code[np.isin(code, np.asarray(model.colour_layers, dtype=np.uint8))] = 0
    code[lo < half_width] = 0  # the sdf band (none when the half width is 0: lo >= 0)
    known = bounds.expand(code, shape)
    layers = np.where(inside, known, np.uint8(0))
    query = inside & (known == 0)
    if half_width > 0:
        query |= ~inside & bounds.expand(lo < half_width, shape)
    return layers, query, bounds.n_queries


def _shell_layers(
    model: StackModel, grid: GridSpec, inside: NDArray[np.bool_], z_start: int
) -> tuple[NDArray[np.uint8], int, int]:
    """Layers as the count of nested surfaces holding each voxel centre.

    Returns the layers ``(Zs, Y, X) uint8``, the unbalanced rows and the nesting
    violations (voxels inside a shell but outside the surface around it).
    """
    z_stop = z_start + inside.shape[0]
    layers = inside.astype(np.uint8)
    previous = inside
    unbalanced = violations = 0
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
    return layers, unbalanced, violations
