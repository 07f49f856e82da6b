"""Shell surfaces from the layer field: one slab-by-slab scan, every layer meshed from it.

The layer field of layer ``k`` at a point ``p`` inside the part is ``D_k(f) - d(p)``, with
``d`` the exact distance to the surface and ``f`` the face of the nearest point (the lowest
index among ties), as the voxel layers use it (:mod:`shellvox.voxel.slab`): negative deeper than the
layer's inner boundary. It is sampled at the nodes of a regular grid of step ``step_mm``
by the project's own scan (:func:`shellvox.voxel.geometry._distance_scan.nearest_in_reach`, out to
the deepest depth plus two steps) and inside test
(:func:`shellvox.voxel.geometry._winding.inside_slab`), one slab of node planes at a time (memory
bounded by the slab), and every layer's zero set is meshed in the same pass by marching tetrahedra
(:mod:`shellvox.offset.field.marching_tets`), each vertex at the exact crossing of its grid
edge. The creases and corners the grid cut off are then put back
(:mod:`shellvox.offset.field.creases`), and the planar patches (most of a faceted part's
surface) triangulated again from their boundaries
(:mod:`shellvox.offset.field.planar_patches`): the same surface, several times fewer triangles.

A deeper layer has a depth at least as large on every face, so its field is no higher at
every node and its marched surface is nested inside the shallower one by construction
(strictly when the thickness is positive); the creases move each surface by at most a grid
step towards the exact offset, which the crossing check of the simplification
(:mod:`shellvox.offset.field.simplify`) verifies.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.offset.field.creases import sharpen_creases
from shellvox.offset.field.marching_tets import (
    EDGES,
    TABLE,
    TETS,
    TRIANGLES_PER_CASE,
    MarchOutputs,
    VertexIds,
    count_triangles,
    march_slab,
)
from shellvox.offset.field.node_field import NodeField
from shellvox.offset.field.planar_patches import merge_planar_patches
from shellvox.voxel._compiled import kernel
from shellvox.voxel.geometry._distance_scan import NearestInReach, nearest_in_reach
from shellvox.voxel.geometry._field_nodes import FieldNodes, NodeLattice
from shellvox.voxel.geometry._nearest import SurfaceIndex
from shellvox.voxel.geometry._voronoi import voronoi_regions
from shellvox.voxel.geometry._winding import inside_slab
from shellvox.voxel.grid import GridSpec

#: Node values allowed in one slab (about 30 bytes a node with two layers, and 13 more for
#: the next slab, scanned meanwhile).
NODES_PER_SLAB = 1 << 24


class FieldSurfaces(NamedTuple):
    """The zero sets of the layer fields, outside in.

    Attributes
    ----------
    surfaces : list of (vertices (V, 3) float64 mm, faces (T, 3) int64)
        One closed, outward-oriented surface per layer (no faces where the layer fills
        the part).
    grid : GridSpec
        The nodes (``voxel_mm`` is the step).
    n_unbalanced_rows : int
        Rows of the inside test whose crossings did not cancel (0 for a closed mesh).
    marched_faces : list of int
        Triangles of each layer as marched, before its creases were put back and its
        planar patches triangulated again.
    crease_points : list of int
        Points each layer got on its creases and corners (:mod:`shellvox.offset.field.creases`).
    """

    surfaces: list[tuple[NDArray[np.float64], NDArray[np.int64]]]
    grid: GridSpec
    n_unbalanced_rows: int
    marched_faces: list[int]
    crease_points: list[int]


def field_grid(vertices: NDArray[np.float64], step_mm: float) -> GridSpec:
    """Return the node grid of step `step_mm` around a mesh, two steps of margin."""
    return GridSpec.from_bounds(
        vertices.min(axis=0), vertices.max(axis=0), (step_mm,) * 3, margin_mm=2 * step_mm
    )


def field_surfaces(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    depth_mm: NDArray[np.float64],
    step_mm: float,
    *,
    nodes_per_slab: int = NODES_PER_SLAB,
    merge_planar: bool = True,
    sharpen: bool = True,
) -> FieldSurfaces:
    """Mesh the zero set of every layer field of a closed mesh on a grid of step `step_mm`.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    depth_mm : (K, F) float64, mm
        Cumulative depth of each layer per face, positive, non-decreasing in ``k``
        (``K <= 8``).
    step_mm : float, mm
        Node spacing (the same on the three axes).
    nodes_per_slab : int, optional
        Nodes scanned at once (bounds the memory).
    merge_planar : bool, optional
        Triangulate the planar patches again (default); False keeps the marched triangles.
    sharpen : bool, optional
        Put the creases and corners back (default; in layers whose faces all have one
        depth); False keeps the chamfers of the grid.

    Returns
    -------
    FieldSurfaces

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((4.0, 4.0, 4.0))
    >>> out = field_surfaces(box.vertices, box.faces, np.full((1, 12), 0.5), 0.25)
    >>> v, f = out.surfaces[0]
    >>> round(float(v[:, 0].max()), 6), trimesh.Trimesh(v, f).is_watertight
    (1.5, True)
    """
    if not (math.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be positive and finite, got {step_mm}")
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    grid = field_grid(vertices, step_mm)
    mesher = FieldMesher(vertices, faces, depth_mm, grid)
    n_z, n_y, n_x = grid.shape_zyx
    reach = mesher.reach_mm
    regions = voronoi_regions(vertices, faces)
    planes = max(2, nodes_per_slab // (n_y * n_x))

    def scan(z_start: int) -> tuple[NDArray[np.bool_], int, NearestInReach]:
        """Scan the node planes ``z_start`` to the slab's end."""
        z_stop = min(n_z, z_start + planes)
        inside, n_bad = inside_slab(vertices, faces, grid, z_start, z_stop)
        near = nearest_in_reach(
            vertices,
            faces,
            grid,
            z_start,
            z_stop,
            reach,
            inside=inside,
            outside_reach_mm=0.0,
            regions=regions,
        )
        return inside, n_bad, near

    starts = range(0, n_z, planes)
    # The next slab is scanned in a second thread while this one is meshed (the kernels
    # release the GIL); it holds one more slab of nodes.
    with ThreadPoolExecutor(1, thread_name_prefix="shellvox-field") as pool:
        ahead = pool.submit(scan, starts[0])
        for index in range(len(starts)):
            inside, n_bad, near = ahead.result()
            if index + 1 < len(starts):
                ahead = pool.submit(scan, starts[index + 1])
            mesher.add(inside, near.squared_mm2, near.face, unbalanced_rows=n_bad)
    return mesher.surfaces(merge_planar=merge_planar, sharpen=sharpen)


class FieldMesher:
    """Mesh the layer fields of a closed mesh from node planes given in order.

    The planes come from a scan of the grid's nodes: :func:`field_surfaces` scans them
    itself; a build gives those its voxels' scan found at every few voxel centres
    (:class:`shellvox.voxel.geometry._field_nodes.NodeLattice`). Each call to :meth:`add` meshes the
    cubes between the planes given so far; :meth:`surfaces` ends the mesh.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    depth_mm : (K, F) float64, mm
        Cumulative depth of each layer per face, positive, non-decreasing in ``k``
        (``K <= 8``).
    grid : GridSpec
        The nodes (any spacing per axis); the nodes of its outermost planes and rows
        must lie outside the mesh.
    """

    def __init__(
        self,
        vertices: NDArray[np.float64],
        faces: NDArray[np.int64],
        depth_mm: NDArray[np.float64],
        grid: GridSpec,
    ) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)
        depth = np.ascontiguousarray(depth_mm, dtype=np.float64)
        n_levels = depth.shape[0]
        if depth.ndim != 2 or depth.shape[1] != len(faces) or not 1 <= n_levels <= 8:
            raise ValueError(
                f"depth_mm must be (K, {len(faces)}) with 1 <= K <= 8, got {depth.shape}"
            )
        self.depth = depth
        self.grid = grid
        self._neighbours = face_neighbours(self.faces)
        normals = _unit_normals(self.vertices, self.faces)
        levels = np.einsum("ij,ij->i", normals, self.vertices[self.faces[:, 0]])
        self._planes = np.ascontiguousarray(np.column_stack([normals, levels]))
        _, n_y, n_x = grid.shape_zyx
        step = np.asarray(grid.voxel_mm, dtype=np.float64)
        #: The nodes' exact nearest face is needed this deep (two of the largest steps
        #: beyond the deepest depth: no edge of the march that crosses a layer reaches
        #: farther).
        self.reach_mm = float(depth.max()) + 2.0 * float(step.max())
        self._far = depth.max(axis=1) - self.reach_mm
        self._outside = float(step.max())
        self._origin = np.asarray(grid.origin_mm, dtype=np.float64)
        self._step = step
        self._ids = VertexIds(
            plane_ids=np.full((2, n_levels, n_y, n_x, 3), -1, dtype=np.int64),
            between_ids=np.full((n_levels, n_y, n_x, 4), -1, dtype=np.int64),
            state=np.zeros((2, n_levels), dtype=np.int64),
        )
        self._v: list[list[NDArray[np.float64]]] = [[] for _ in range(n_levels)]
        self._f: list[list[NDArray[np.int64]]] = [[] for _ in range(n_levels)]
        self._face: list[list[NDArray[np.int32]]] = [[] for _ in range(n_levels)]
        self._last: tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.int32]] | None = None
        self._next_plane = 0
        self._unbalanced = 0

    def add(
        self,
        inside: NDArray[np.bool_],
        squared: NDArray[np.float64],
        face: NDArray[np.int32],
        *,
        unbalanced_rows: int = 0,
    ) -> None:
        """Mesh the next node planes.

        Parameters
        ----------
        inside : (P, Y, X) bool
            Nodes inside the mesh (the planes after those given before).
        squared : (P, Y, X) float64, mm^2
            Squared distance to the nearest face where ``face >= 0``.
        face : (P, Y, X) int32
            Nearest face (lowest index among ties) of every inside node within
            :attr:`reach_mm`, -1 beyond it.
        unbalanced_rows : int, optional
            Rows of the inside test whose crossings did not cancel (reported).
        """
        n_y, n_x = self.grid.shape_zyx[1:]
        if inside.shape[1:] != (n_y, n_x) or not inside.shape == squared.shape == face.shape:
            raise ValueError(
                f"node planes must be (P, {n_y}, {n_x}), got {inside.shape}, {squared.shape} "
                f"and {face.shape}"
            )
        self._unbalanced += unbalanced_rows
        if not len(inside):
            return
        z_base = self._next_plane
        self._next_plane += len(inside)
        if self._last is not None:
            inside, squared, face = (
                np.concatenate([kept, new])
                for kept, new in zip(self._last, (inside, squared, face), strict=True)
            )
            z_base -= 1
        self._last = (inside[-1:].copy(), squared[-1:].copy(), face[-1:].copy())
        if len(inside) < 2:
            return
        n_levels = self.depth.shape[0]
        bits = np.empty(inside.shape, dtype=np.uint8)
        _layer_bits(inside, squared, face, self.depth, bits)
        counts = count_triangles(bits, n_levels, TETS, TRIANGLES_PER_CASE)
        f_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        v_start = 3 * f_start
        new_vertices = np.empty((int(v_start[-1]), 3))
        new_faces = np.empty((int(f_start[-1]), 3), dtype=np.int64)
        new_vertex_face = np.empty(int(v_start[-1]), dtype=np.int32)
        field = NodeField(
            bits,
            inside,
            squared,
            face,
            self.depth,
            self._far,
            self._outside,
            self._origin,
            self._step,
            z_base,
            self.vertices,
            self.faces,
            self._neighbours,
            self._planes,
        )
        out = MarchOutputs(new_vertices, v_start, new_faces, f_start, new_vertex_face)
        made = march_slab(field, self._ids, (EDGES, TETS, TABLE), out)
        for k in range(n_levels):
            self._v[k].append(new_vertices[v_start[k] : v_start[k] + made[k]])
            self._f[k].append(new_faces[f_start[k] : f_start[k + 1]])
            self._face[k].append(new_vertex_face[v_start[k] : v_start[k] + made[k]])

    def surfaces(self, *, merge_planar: bool = True, sharpen: bool = True) -> FieldSurfaces:
        """Return the layers' surfaces, once every node plane was given.

        `sharpen`: put the creases and corners back (default; in a layer whose faces all
        have one depth); `merge_planar`: triangulate the planar patches again (default).
        False keeps the marched triangles.
        """
        n_planes = self.grid.shape_zyx[0]
        if self._next_plane != n_planes:
            raise ValueError(f"{self._next_plane} of {n_planes} node planes were given")
        depth = self.depth
        normals = np.ascontiguousarray(self._planes[:, :3])
        surface = SurfaceIndex.build(self.vertices, self.faces)
        plane_levels = self._planes[:, 3] - depth

        def level(k: int) -> tuple[NDArray[np.float64], NDArray[np.int64], int, int]:
            v = np.concatenate(self._v[k]) if self._v[k] else np.zeros((0, 3))
            f = np.concatenate(self._f[k]) if self._f[k] else np.zeros((0, 3), dtype=np.int64)
            n_marched = len(f)
            if not len(f):
                return v, f, n_marched, 0
            vertex_face = np.concatenate(self._face[k])
            on_several = None
            # Creases are put back in layers of one depth; where the depth differs between
            # faces the checks are local and do not cover the steps between depths.
            if sharpen and np.ptp(depth[k]) == 0.0:
                sharp = sharpen_creases(
                    v, f, vertex_face, normals, plane_levels[k], depth[k], surface
                )
                v, f, vertex_face, on_several = (
                    sharp.vertices,
                    sharp.faces,
                    sharp.vertex_face,
                    sharp.on_crease,
                )
            n_points = int(on_several.sum()) if on_several is not None else 0
            if not merge_planar:
                return v, f, n_marched, n_points
            merged = merge_planar_patches(
                v, f, vertex_face, normals, plane_levels[k], on_several=on_several
            )
            return merged.vertices, merged.faces, n_marched, n_points

        # The layers are finished side by side (the kernels and GEOS release the GIL).
        n_levels = depth.shape[0]
        with ThreadPoolExecutor(min(n_levels, 2), thread_name_prefix="shellvox-patches") as pool:
            done = list(pool.map(level, range(n_levels)))
        return FieldSurfaces(
            [(v, f) for v, f, _, _ in done],
            self.grid,
            self._unbalanced,
            [n for _, _, n, _ in done],
            [c for _, _, _, c in done],
        )


class LatticeMesher(FieldMesher):
    """Mesh the layer fields from a build's voxels: the :class:`FieldNodes` of its slabs.

    The nodes are the :class:`NodeLattice`'s voxel centres with one more node, outside,
    on every side; the slabs' nodes are given in z order (:meth:`add_nodes`).

    Parameters
    ----------
    vertices, faces, depth_mm
        As :class:`FieldMesher`.
    voxels : GridSpec
        The build's voxel grid.
    lattice : NodeLattice
        The voxel centres kept (its ``beyond_mm`` at least two node steps).
    """

    def __init__(
        self,
        vertices: NDArray[np.float64],
        faces: NDArray[np.int64],
        depth_mm: NDArray[np.float64],
        voxels: GridSpec,
        lattice: NodeLattice,
    ) -> None:
        stride_zyx = np.asarray(lattice.stride_zyx)
        count = -(-np.asarray(voxels.shape_zyx) // stride_zyx)  # nodes per axis
        step = np.asarray(voxels.voxel_mm) * stride_zyx[::-1]
        origin = np.asarray(voxels.origin_mm) - step
        grid = GridSpec(
            (float(origin[0]), float(origin[1]), float(origin[2])),
            (float(step[0]), float(step[1]), float(step[2])),
            (int(count[0]) + 2, int(count[1]) + 2, int(count[2]) + 2),
        )
        super().__init__(vertices, faces, depth_mm, grid)
        if lattice.beyond_mm < 2.0 * float(step.max()) * (1 - 1e-9):
            raise ValueError(
                f"the lattice's nodes are scanned {lattice.beyond_mm} mm beyond the deepest "
                f"depth; its steps {step.tolist()} mm need {2.0 * float(step.max())}"
            )
        self._expected = 0
        self._add_outside()

    def add_nodes(self, nodes: FieldNodes) -> None:
        """Mesh one slab's nodes (the slab after the last one given)."""
        if nodes.first != self._expected:
            raise ValueError(f"node plane {nodes.first} came where {self._expected} was due")
        self._expected += len(nodes.inside)
        pad = ((0, 0), (1, 1), (1, 1))
        self.add(
            np.pad(nodes.inside, pad),
            np.pad(nodes.squared, pad),
            np.pad(nodes.face, pad, constant_values=-1),
        )

    def surfaces(self, *, merge_planar: bool = True, sharpen: bool = True) -> FieldSurfaces:
        """Return the layers' surfaces once every slab's nodes were given."""
        if self._expected != self.grid.shape_zyx[0] - 2:
            raise ValueError(
                f"{self._expected} of {self.grid.shape_zyx[0] - 2} node planes were given"
            )
        self._add_outside()
        return super().surfaces(merge_planar=merge_planar, sharpen=sharpen)

    def _add_outside(self) -> None:
        """Mesh one plane of nodes outside the mesh."""
        shape = (1, *self.grid.shape_zyx[1:])
        self.add(np.zeros(shape, bool), np.zeros(shape), np.full(shape, -1, np.int32))


def face_neighbours(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Return the face across each edge ``(f[i], f[i+1])`` of every face, (F, 3) int64.

    -1 where the edge does not have exactly two faces.

    >>> face_neighbours(np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [[-1, -1, 1], [0, -1, -1]]
    """
    n = len(faces)
    if n == 0:
        return np.zeros((0, 3), dtype=np.int64)
    a, b = faces, np.roll(faces, -1, axis=1)
    key = (np.minimum(a, b) * (int(faces.max()) + 1) + np.maximum(a, b)).ravel()
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    start = np.flatnonzero(np.concatenate([[True], sorted_key[1:] != sorted_key[:-1]]))
    count = np.diff(np.concatenate([start, [len(key)]]))
    pairs = start[count == 2]
    first, second = order[pairs], order[pairs + 1]
    out = np.full(3 * n, -1, dtype=np.int64)
    out[first] = second // 3
    out[second] = first // 3
    return out.reshape(n, 3)


def _unit_normals(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Return the unit outward normal of every face, (F, 3) float64 (NaN without area)."""
    corner = vertices[faces]
    normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        unit: NDArray[np.float64] = normal / np.linalg.norm(normal, axis=1)[:, None]
    return unit


@kernel
def _layer_bits(
    inside: NDArray[np.bool_],
    squared: NDArray[np.float64],
    face: NDArray[np.int32],
    depth: NDArray[np.float64],
    bits: NDArray[np.uint8],
) -> None:
    """Set bit ``k`` of a node where it lies inside layer ``k`` (field ``<= 0``, ties inside).

    The same expression as :func:`shellvox.offset.field.node_field.node_value`,
    so a crossed edge always has one value ``<= 0`` and one ``> 0``.
    """
    flat_inside = inside.reshape(-1)
    flat_squared = squared.reshape(-1)
    flat_face = face.reshape(-1)
    flat_bits = bits.reshape(-1)
    n_levels = depth.shape[0]
    for i in range(flat_bits.size):
        if not flat_inside[i]:
            flat_bits[i] = 0
            continue
        f = flat_face[i]
        if f < 0:
            flat_bits[i] = (1 << n_levels) - 1
            continue
        d = np.sqrt(flat_squared[i])
        b = 0
        for k in range(n_levels):
            if depth[k, f] - d <= 0.0:
                b |= 1 << k
        flat_bits[i] = b
