"""Shell surfaces from the layer field: one slab-by-slab scan, every layer meshed from it.

The layer field of layer ``k`` at a point ``p`` inside the part is ``D_k(f) - d(p)``, with
``d`` the exact distance to the surface and ``f`` the face of the nearest point (the lowest
index among ties), as the voxel layers use it (:mod:`shellvox.voxel.slab`): negative deeper than the
layer's inner boundary. It is sampled at the nodes of a regular grid of step ``step_mm``
by the project's own scan (:func:`shellvox.voxel.geometry._distance_scan.nearest_in_reach`, out to
the deepest depth plus two steps) and inside test
(:func:`shellvox.voxel.geometry._winding.inside_slab`), one slab of node planes at a time (memory
bounded by the slab), and every layer's zero set is meshed in the same pass by marching tetrahedra
(:mod:`shellvox.offset.field.marching_tets`). Its planar patches (most of a faceted part's
surface) are then triangulated again from their boundaries
(:mod:`shellvox.offset.field.planar_patches`): the same surface, several times fewer triangles.

A deeper layer has a depth at least as large on every face, so its field is no higher at
every node and its surface is nested inside the shallower one by construction (strictly
when the thickness is positive).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.offset.field.marching_tets import (
    EDGES,
    TABLE,
    TETS,
    TRIANGLES_PER_CASE,
    MarchOutputs,
    NodeField,
    VertexIds,
    count_triangles,
    march_slab,
)
from shellvox.offset.field.planar_patches import merge_planar_patches
from shellvox.voxel._compiled import kernel
from shellvox.voxel.geometry._distance_scan import NearestInReach, nearest_in_reach
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
        Triangles of each layer as marched, before its planar patches were triangulated
        again.
    """

    surfaces: list[tuple[NDArray[np.float64], NDArray[np.int64]]]
    grid: GridSpec
    n_unbalanced_rows: int
    marched_faces: list[int]


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
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    depth = np.ascontiguousarray(depth_mm, dtype=np.float64)
    n_levels = depth.shape[0]
    if depth.ndim != 2 or depth.shape[1] != len(faces) or not 1 <= n_levels <= 8:
        raise ValueError(f"depth_mm must be (K, {len(faces)}) with 1 <= K <= 8, got {depth.shape}")
    if not (math.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be positive and finite, got {step_mm}")
    grid = field_grid(vertices, step_mm)
    n_z, n_y, n_x = grid.shape_zyx
    reach = float(depth.max()) + 2.0 * step_mm
    far = depth.max(axis=1) - reach
    regions = voronoi_regions(vertices, faces)
    origin = np.asarray(grid.origin_mm, dtype=np.float64)
    step = np.asarray(grid.voxel_mm, dtype=np.float64)
    ids = VertexIds(
        plane_ids=np.full((2, n_levels, n_y, n_x, 3), -1, dtype=np.int64),
        between_ids=np.full((n_levels, n_y, n_x, 4), -1, dtype=np.int64),
        state=np.zeros((2, n_levels), dtype=np.int64),
    )
    tables = (EDGES, TETS, TABLE)
    out_v: list[list[NDArray[np.float64]]] = [[] for _ in range(n_levels)]
    out_f: list[list[NDArray[np.int64]]] = [[] for _ in range(n_levels)]
    out_face: list[list[NDArray[np.int32]]] = [[] for _ in range(n_levels)]
    planes = max(2, nodes_per_slab // (n_y * n_x))
    unbalanced = 0

    def scan(
        z_start: int, before: NDArray[np.bool_]
    ) -> tuple[int, NDArray[np.bool_], int, NearestInReach, NDArray[np.uint8]]:
        """Scan the node planes ``z_start`` to the slab's end and the plane before them.

        `before` is the inside test of that plane ((1, Y, X), from the slab before; (0, Y, X)
        for the first slab), so the arrays returned run from it on and the slabs' meshes
        meet without copying a plane over. Returns the arrays' first plane with them.
        """
        z_stop = min(n_z, z_start + planes)
        z_first = z_start - len(before)
        own, n_bad = inside_slab(vertices, faces, grid, z_start, z_stop)
        inside = np.concatenate([before, own]) if len(before) else own
        near = nearest_in_reach(
            vertices,
            faces,
            grid,
            z_first,
            z_stop,
            reach,
            inside=inside,
            outside_reach_mm=0.0,
            regions=regions,
        )
        bits = np.empty(inside.shape, dtype=np.uint8)
        _layer_bits(inside, near.squared_mm2, near.face, depth, bits)
        return z_first, inside, n_bad, near, bits

    starts = range(0, n_z, planes)
    # The next slab is scanned in a second thread while this one is meshed (the kernels
    # release the GIL); it holds one more slab of nodes.
    with ThreadPoolExecutor(1, thread_name_prefix="shellvox-field") as pool:
        ahead = pool.submit(scan, starts[0], np.zeros((0, n_y, n_x), dtype=bool))
        for index in range(len(starts)):
            z_base, inside, n_bad, near, bits = ahead.result()
            if index + 1 < len(starts):
                ahead = pool.submit(scan, starts[index + 1], inside[-1:])
            unbalanced += n_bad
            if len(bits) < 2:
                continue
            counts = count_triangles(bits, n_levels, TETS, TRIANGLES_PER_CASE)
            f_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            v_start = 3 * f_start
            new_vertices = np.empty((int(v_start[-1]), 3))
            new_faces = np.empty((int(f_start[-1]), 3), dtype=np.int64)
            new_vertex_face = np.empty(int(v_start[-1]), dtype=np.int32)
            field = NodeField(
                bits, inside, near.squared_mm2, near.face, depth, far, step_mm, origin, step, z_base
            )
            out = MarchOutputs(new_vertices, v_start, new_faces, f_start, new_vertex_face)
            made = march_slab(field, ids, tables, out)
            for k in range(n_levels):
                out_v[k].append(new_vertices[v_start[k] : v_start[k] + made[k]])
                out_f[k].append(new_faces[f_start[k] : f_start[k + 1]])
                out_face[k].append(new_vertex_face[v_start[k] : v_start[k] + made[k]])
    normals = _unit_normals(vertices, faces)
    plane_at = np.einsum("ij,ij->i", normals, vertices[faces[:, 0]])

    def level(k: int) -> tuple[NDArray[np.float64], NDArray[np.int64], int]:
        v = np.concatenate(out_v[k]) if out_v[k] else np.zeros((0, 3))
        f = np.concatenate(out_f[k]) if out_f[k] else np.zeros((0, 3), dtype=np.int64)
        if not (merge_planar and len(f)):
            return v, f, len(f)
        vertex_face = np.concatenate(out_face[k])
        merged = merge_planar_patches(v, f, vertex_face, normals, plane_at - depth[k])
        return merged.vertices, merged.faces, len(f)

    # The layers' patches are merged side by side (the kernels and GEOS release the GIL).
    with ThreadPoolExecutor(min(n_levels, 2), thread_name_prefix="shellvox-patches") as pool:
        done = list(pool.map(level, range(n_levels)))
    surfaces = [(v, f) for v, f, _ in done]
    marched = [n for _, _, n in done]
    return FieldSurfaces(surfaces, grid, unbalanced, marched)


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

    The same expression as :func:`shellvox.offset.field.marching_tets.march_slab`'s node value,
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
