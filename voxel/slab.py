"""One Z slab of the layered voxel stack: a pure function of the model, the grid and the rows.

:func:`compute_slab` returns arrays only (no files), so slabs can run in any order or in
parallel and runs can resume.

Two layer realisations:

* **distance** (``StackModel.layer_rule == "distance"``, with ``depth_mm``): a voxel
  inside the outer surface lies in band ``k`` when ``D_{k-1}(f) <= d < D_k(f)``, with
  ``d`` its exact distance to the original surface and ``f`` the face of its nearest
  point; this is the ideal offset (rounded at reflex features, collapsing in thin walls)
  sampled exactly at the voxel centres. Every face is scan-converted into the voxels
  within the deepest band limit (:mod:`shellvox.voxel.geometry._distance_scan`, compiled), which
  gives each of them its exact nearest face; deeper inside voxels are core by the inside test alone.
* **shells** (``layer_rule == "shells"``, no ``depth_mm``): a voxel's layer is how many
  of the nested closed surfaces ``surfaces`` contain its centre (exact winding numbers).

A model whose faces are not one closed, oriented surface (open, non-manifold, parts
pushed into each other) carries its :class:`SoupSolid`: the inside is where the soup's
generalised winding number is at least 1/2 (:func:`shellvox.voxel.geometry.solid_slab`),
``surfaces[0]`` holds its visible faces only (those between inside and outside), and a
voxel's distance is the smaller of its exact distance to them and its distance to the
nearest voxel centre outside (where the winding number closes a hole there is no face:
the cap's distance is within a voxel of the true one).

With a :class:`NodeLattice` (distance layers whose shells are meshed too), a slab also
returns what the scan found at every ``stride``-th voxel centre (:class:`FieldNodes`): the
layer field there, which :class:`shellvox.offset.field.layer_field.FieldMesher` meshes, so
the shells need no scan of their own. The scan then reaches two node steps beyond the
deepest depth (the march's edges cross it); the voxels' layers, colours and signed distances
do not change with the reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour import ColourAt, SurfaceColour, nearest_colour, voxel_colours
from shellvox.voxel.geometry import (
    FieldNodes,
    LayerInputs,
    LayerOutputs,
    NodeLattice,
    SoupSolid,
    SurfaceIndex,
    assign_layers,
    colour_voxels,
    inside_slab,
    nearest_faces,
    nearest_in_reach,
    nearest_within,
    on_faces,
    solid_slab,
)
from shellvox.voxel.grid import GridSpec

Surface = tuple[NDArray[np.float64], NDArray[np.int64]]

#: How a voxel gets its layer (see the module): its exact distance to the surface, or the
#: count of offset shells holding it.
LayerRule = Literal["distance", "shells"]


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
        ``k``); required by the ``"distance"`` rule (``surfaces`` then needs only the
        original), refused by ``"shells"``.
    surface_colour : SurfaceColour, optional
        The colour source as arrays: colours by the compiled kernel
        (:mod:`shellvox.voxel.colour._surface_colour`), which gives what `colour_at` gives.
    layer_rule : {"shells", "distance"}
        How voxels get their layer (see the module).
    field_nodes : NodeLattice, optional
        Keep the layer field at these voxel centres (distance layers only).
    solid : SoupSolid, optional
        All the faces of a model as it comes, where ``surface`` holds its visible faces
        only: their winding number decides the inside (or, with `solid_closed`, the
        exact crossings of ``surfaces[0]``, the same faces), and a voxel's distance is
        also measured to the outside (see the module); distance layers only.
    solid_closed : bool
        The solid's faces are closed and oriented (parts pushed into each other): the
        inside is ``surfaces[0]``'s exact crossings.
    partly : (F,) bool, optional
        Faces of ``surface`` visible only in part: where a voxel's nearest point lies on
        their buried piece, its distance is to the outside instead.
    """

    surfaces: tuple[Surface, ...]
    surface: SurfaceIndex
    colour_at: ColourAt
    colour_layers: tuple[int, ...] = (1,)
    sdf_half_width_mm: float = 0.0
    depth_mm: NDArray[np.float64] | None = None
    surface_colour: SurfaceColour | None = None
    layer_rule: LayerRule = "shells"
    field_nodes: NodeLattice | None = None
    solid: SoupSolid | None = None
    solid_closed: bool = False
    partly: NDArray[np.bool_] | None = None

    def __post_init__(self) -> None:
        if not self.surfaces:
            raise ValueError("surfaces must hold at least the original surface, got none")
        if self.solid is not None and self.layer_rule != "distance":
            raise ValueError("a soup's solid needs the 'distance' layer rule")
        if self.layer_rule not in ("distance", "shells"):
            raise ValueError(f"layer_rule must be 'distance' or 'shells', got {self.layer_rule!r}")
        if (self.depth_mm is None) != (self.layer_rule == "shells"):
            raise ValueError(
                f"depth_mm must be given with layer_rule 'distance' and only then, got "
                f"layer_rule {self.layer_rule!r} and depth_mm "
                f"{'None' if self.depth_mm is None else self.depth_mm.shape}"
            )
        if self.depth_mm is not None:
            depth = self.depth_mm
            n_faces = len(self.surface.faces)
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
        if self.field_nodes is not None and (
            self.layer_rule != "distance"
            or min(self.field_nodes.stride_zyx) < 1
            or not self.field_nodes.beyond_mm >= 0
        ):
            raise ValueError(
                "field_nodes needs the 'distance' layer rule, strides >= 1 and beyond_mm >= 0, "
                f"got {self.layer_rule!r} and {self.field_nodes}"
            )

    @property
    def n_bands(self) -> int:
        """Number of shell bands ``K`` (the core is layer ``K + 1``)."""
        if self.layer_rule == "distance" and self.depth_mm is not None:
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
        Voxels given their exact nearest face (by the scan, or by a query beyond it).
    n_distance_tests : int
        Point-triangle distance tests of the scan (its work).
    layer_counts : (K + 2,) int64
        Voxels per layer (0 outside .. K + 1 core).
    nodes : FieldNodes or None
        The layer field at the model's :class:`NodeLattice` in these rows (None without).
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
    n_distance_tests: int
    layer_counts: NDArray[np.int64]
    nodes: FieldNodes | None = None


def reach_mm(model: StackModel) -> float:
    """Return the distance (mm) within which inside voxels need their nearest face.

    Distance layers need it out to the deepest band limit, so anything farther is core
    (and the nodes of the shell meshes a little farther, :class:`NodeLattice`);
    the signed-distance band needs it out to its half width. Shell layers need the
    nearest face only for colour, which is found by a query where it lies farther.
    """
    if model.layer_rule == "distance" and model.depth_mm is not None:
        beyond = 0.0 if model.field_nodes is None else model.field_nodes.beyond_mm
        return max(float(model.depth_mm.max()) + beyond, model.sdf_half_width_mm)
    return model.sdf_half_width_mm


def compute_slab(model: StackModel, grid: GridSpec, z_start: int, z_stop: int) -> SlabResult:
    """Return layers, colours and the signed-distance band of rows ``z_start..z_stop``.

    Needs no halo: inside tests run along x rows and every face within reach of the
    slab is scan-converted into it (:mod:`shellvox.voxel.geometry._distance_scan`), so a slab reads
    nothing beyond its own rows and any split into slabs gives the same arrays.

    Parameters
    ----------
    model : StackModel
        Surfaces, colour source and options (a tray of models is computed tile by tile
        with :func:`shellvox.voxel.tray_slab.compute_tray_slab`, which calls this per tile).
    grid : GridSpec
        The voxel grid.
    z_start, z_stop : int
        Rows of the slab, ``0 <= z_start < z_stop <= Z``.

    Returns
    -------
    SlabResult
        Arrays of shape ``(z_stop - z_start, Y, X)``; memory is about 24 bytes a voxel.
    """
    n_z = grid.shape_zyx[0]
    if not 0 <= z_start < z_stop <= n_z:
        raise ValueError(
            f"slab rows must satisfy 0 <= z_start < z_stop <= {n_z}, got {z_start}, {z_stop}"
        )
    vertices, faces = model.surfaces[0]
    outside_mm = None
    if model.solid is None:
        inside, unbalanced = inside_slab(vertices, faces, grid, z_start, z_stop)
    else:
        inside, outside_mm, unbalanced = _soup_inside(model, grid, z_start, z_stop)
    shape = (inside.shape[0], inside.shape[1], inside.shape[2])
    half_width = model.sdf_half_width_mm
    violations = 0
    by_distance = model.layer_rule == "distance" and model.depth_mm is not None
    if not by_distance:
        layers, unbalanced_shells, violations = _shell_layers(model, grid, inside, z_start)
        unbalanced += unbalanced_shells
        depth = np.zeros((0, len(faces)))
    else:
        layers = np.empty(shape, dtype=np.uint8)
        depth = np.ascontiguousarray(model.depth_mm, dtype=np.float64)
    reach = reach_mm(model)
    if reach > 0:
        near = nearest_in_reach(
            model.surface.vertices,
            model.surface.faces,
            grid,
            z_start,
            z_stop,
            reach,
            inside=inside,
            outside_reach_mm=half_width,
            regions=model.surface.regions,
        )
        squared, face, n_tests = near
        if outside_mm is not None:
            _cap_distances(model.surface, grid, z_start, inside, outside_mm, reach, squared, face)
            if model.solid is not None and model.partly is not None and model.partly.any():
                surface_distances = SurfaceDistances(squared, face, inside, outside_mm)
                _buried_nearest(model, grid, z_start, surface_distances)
    else:
        squared = np.zeros(shape)
        face = np.full(shape, -1, dtype=np.int32)
        n_tests = 0
    is_colour = np.zeros(256, dtype=bool)
    is_colour[list(model.colour_layers)] = True
    sdf = np.empty(shape, dtype=np.float32)
    sdf_band = np.empty(shape, dtype=bool)
    layer_counts = np.zeros(256, dtype=np.int64)
    n_colour, n_unreached, n_reached = assign_layers(
        LayerInputs(inside, squared, face, depth, by_distance, half_width, is_colour),
        LayerOutputs(layers, sdf, sdf_band, layer_counts),
    )
    nodes = None
    if model.field_nodes is not None:
        nodes = _field_nodes(model.field_nodes, z_start, inside, squared, face)
    del squared
    flat = colour_voxels(layers, is_colour, n_colour)
    face_ids = face.reshape(-1)[flat].astype(np.int64)
    del face
    index = np.stack(np.unravel_index(flat, shape), axis=1)
    index[:, 0] += z_start
    points = grid.index_to_world(index)
    del index
    if n_unreached:
        face_ids = _beyond_reach(model.surface, grid, z_start, shape, flat, points, face_ids)
    rgba = np.zeros((*shape, 4), dtype=np.uint8)
    if model.surface_colour is not None:
        rgba.reshape(-1, 4)[flat] = voxel_colours(
            points, face_ids, model.surface.vertices, model.surface.faces, model.surface_colour
        )
    else:
        nearest = on_faces(model.surface, points, face_ids)
        rgba.reshape(-1, 4)[flat] = nearest_colour(nearest, model.colour_at)
    del points
    return SlabResult(
        z_start,
        z_stop,
        layers,
        rgba,
        sdf,
        sdf_band,
        unbalanced,
        violations,
        n_reached + n_unreached,
        n_tests,
        layer_counts[: model.n_bands + 2],
        nodes,
    )


class SurfaceDistances(NamedTuple):
    """A slab's distances as the scan found them, corrected in place for a soup."""

    squared: NDArray[np.float64]
    face: NDArray[np.int32]
    inside: NDArray[np.bool_]
    outside_mm: NDArray[np.float64]


def _soup_inside(
    model: StackModel, grid: GridSpec, z_start: int, z_stop: int
) -> tuple[NDArray[np.bool_], NDArray[np.float64], int]:
    """Return a soup's inside, each voxel's distance (mm) to the outside, unbalanced rows.

    The distance is to the nearest voxel centre outside. The inside is computed over the
    slab and the rows within the reach of it, so the distance (exact on the voxel
    centres, :func:`scipy.ndimage.distance_transform_edt` at the grid's spacing) is that
    of the whole grid within the reach; farther it is at least the reach.
    """
    from scipy import ndimage

    assert model.solid is not None
    reach = reach_mm(model)
    n_z = grid.shape_zyx[0]
    halo = int(np.ceil(reach / grid.voxel_mm[2])) + 1 if reach > 0 else 0
    low, high = max(0, z_start - halo), min(n_z, z_stop + halo)
    unbalanced = 0
    if model.solid_closed:
        vertices, faces = model.surfaces[0]
        inside, unbalanced = inside_slab(vertices, faces, grid, low, high)
    else:
        inside = solid_slab(model.solid, grid, low, high).inside
    spacing = (grid.voxel_mm[2], grid.voxel_mm[1], grid.voxel_mm[0])
    distance = ndimage.distance_transform_edt(inside, sampling=spacing)
    rows = slice(z_start - low, z_stop - low)
    return (
        np.ascontiguousarray(inside[rows]),
        np.asarray(distance[rows], dtype=np.float64),
        unbalanced,
    )


def _buried_nearest(
    model: StackModel, grid: GridSpec, z_start: int, slab: SurfaceDistances
) -> None:
    """Give voxels nearest to a buried piece of a face their distance to the outside.

    The face is kept, for its depth and colour. A point of a face is buried where the
    winding number just off it, on its outer side, is at least 1/2 (the solid lies on
    both sides).
    """
    assert model.solid is not None and model.partly is not None
    face = slab.face.reshape(-1)
    reached = (slab.inside.reshape(-1)) & (face >= 0)
    flat = np.flatnonzero(reached)
    flat = flat[model.partly[face[flat]]]
    if not len(flat):
        return
    index = np.stack(np.unravel_index(flat, slab.inside.shape), axis=1)
    index[:, 0] += z_start
    ids = face[flat].astype(np.int64)
    near = on_faces(model.surface, grid.index_to_world(index), ids)
    triangles = model.surface.vertices[model.surface.faces[ids]]
    point = np.einsum("nc,nck->nk", near.barycentric, triangles)
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    side = 1e-3 * float(min(grid.voxel_mm))
    buried = model.solid.tree.evaluate(point + side * normal) >= 0.5
    chosen = flat[buried]
    slab.squared.reshape(-1)[chosen] = np.square(slab.outside_mm.reshape(-1)[chosen])


def _cap_distances(
    surface: SurfaceIndex,
    grid: GridSpec,
    z_start: int,
    inside: NDArray[np.bool_],
    outside_mm: NDArray[np.float64],
    reach: float,
    squared: NDArray[np.float64],
    face: NDArray[np.int32],
) -> None:
    """Take the distance to the outside where it is less than that to a visible face.

    Where the winding number closes a hole there is no face: a voxel's distance to the
    solid's boundary is then its distance to the nearest centre outside (at most a voxel
    more than the true one). A voxel that no face lies within `reach` of, but the outside
    does, takes the face nearest to it (for the depth of its layers and its colour).
    """
    closer = inside & (outside_mm * outside_mm < squared)
    np.copyto(squared, outside_mm * outside_mm, where=closer)
    lonely = np.flatnonzero((closer & (face < 0) & (outside_mm < reach)).reshape(-1))
    if len(lonely):
        index = np.stack(np.unravel_index(lonely, inside.shape), axis=1)
        index[:, 0] += z_start
        face.reshape(-1)[lonely] = nearest_faces(surface, grid.index_to_world(index))[0]


def _field_nodes(
    lattice: NodeLattice,
    z_start: int,
    inside: NDArray[np.bool_],
    squared: NDArray[np.float64],
    face: NDArray[np.int32],
) -> FieldNodes:
    """Return the slab's arrays at the lattice's nodes (copies: the slab's are let go)."""
    stride_z, stride_y, stride_x = lattice.stride_zyx
    rows = lattice.planes(z_start, z_start + len(inside))
    at = (
        slice(rows.start - z_start, None, stride_z),
        slice(None, None, stride_y),
        slice(None, None, stride_x),
    )
    return FieldNodes(
        rows.start // stride_z,
        np.ascontiguousarray(inside[at]),
        np.ascontiguousarray(squared[at]),
        np.ascontiguousarray(face[at]),
    )


def _beyond_reach(
    surface: SurfaceIndex,
    grid: GridSpec,
    z_start: int,
    shape: tuple[int, int, int],
    flat: NDArray[np.int64],
    points: NDArray[np.float64],
    face_ids: NDArray[np.int64],
) -> NDArray[np.int64]:
    """Fill in the nearest faces (-1 in ``face_ids``) of colour voxels beyond the reach.

    Shell layers, or a coloured core, can lie deeper than the scan's reach. The tree
    gives each such voxel its distance; a second scan out to just that distance then
    picks its face by the same rule as the first (lowest index among ties), so a voxel's
    colour does not depend on how far it lies.
    """
    far = np.flatnonzero(face_ids < 0)
    distance = nearest_faces(surface, points[far])[1]
    wanted = np.zeros(shape)
    wanted.reshape(-1)[flat[far]] = (distance * (1 + 1e-9) + 1e-12) ** 2
    again = nearest_within(surface.vertices, surface.faces, grid, z_start, wanted, surface.regions)
    face_ids = face_ids.copy()
    face_ids[far] = again.face.reshape(-1)[flat[far]]
    return face_ids


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
        contained, shell_unbalanced = inside_slab(
            shell_vertices, shell_faces, grid, z_start, z_stop
        )
        unbalanced += shell_unbalanced
        violations += int(np.count_nonzero(contained & ~previous))
        layers += contained
        previous = contained
    return layers, unbalanced, violations
