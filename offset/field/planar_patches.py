"""Planar patches of a marched surface, triangulated again from their boundaries alone.

Marching tetrahedra on a grid of step ``h`` makes about nine triangles per ``h^2`` of
surface. Where the nearest face of both nodes of every crossed edge is the same face ``f``
and its field is linear (the nearest point inside the face), the vertices lie on ``f``'s
offset plane, so most of a faceted part's layer surface is planar patches of thousands of
triangles each. A patch (triangles connected across edges, every vertex within
``PLANE_TOLERANCE_MM`` of one plane parallel to the same face's offset plane) is replaced
by a constrained Delaunay triangulation of its boundary loops in that plane (GEOS, through
``shapely.constrained_delaunay_triangles``): every boundary vertex and edge is kept and the
interior vertices go, so the surface covers the same points, stays closed, 2-manifold,
free of self-intersections and nested with the other layers, with about
``boundary vertices + 2 holes - 2`` triangles per patch.

Where a patch's boundary touches itself at a vertex (not a simple polygon), the patch's
triangles at that vertex stay as they are and the rest is a patch again. A patch is kept as
marched where its loops are not one outer ring (anticlockwise seen from outside) and holes,
GEOS finds the polygon invalid, or the new triangles fail the check: every corner a
boundary vertex, each directed edge used once, the unpaired edges exactly the boundary,
positive areas and the polygon's area in all.

A crease or corner point (:mod:`shellvox.offset.field.creases`) lies on two or three planes:
a triangle with one belongs to the patch of any of its corners' planes that holds all
three corners.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import shapely
from numpy.typing import NDArray

from shellvox.offset.field.patch_topology import boundary_loops, patches, twins
from shellvox.voxel._compiled import kernel

#: Vertices of a patch lie within this distance (mm) of one plane.
PLANE_TOLERANCE_MM = 1e-9

#: Largest distance (mm) of a vertex from its face's offset plane for it to be in a patch.
MAX_OFFSET_MM = 1e-6

#: Whole tolerances in the largest offset.
QUANTA = round(MAX_OFFSET_MM / PLANE_TOLERANCE_MM)

#: Rounds of taking the triangles at a touching vertex out of their patch.
UNTOUCH_ROUNDS = 4

#: Relative tolerance of a patch's area against the sum of its new triangles'.
AREA_TOLERANCE = 1e-9


class Merged(NamedTuple):
    """A surface with its planar patches triangulated again.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (T, 3) int64
        Outward-oriented triangles (unreferenced vertices removed).
    patches : int
        Patches triangulated again.
    faces_before : int
        Triangles of the marched surface.
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    patches: int
    faces_before: int


def merge_planar_patches(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    vertex_face: NDArray[np.int32],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    *,
    on_several: NDArray[np.bool_] | None = None,
) -> Merged:
    """Triangulate the planar patches of a closed, outward-oriented surface again.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (T, 3) int64
        Closed, 2-manifold, outward-oriented triangles.
    vertex_face : (V,) int32
        A face whose offset plane each vertex may lie on, -1 for none.
    normals : (F, 3) float64
        Unit outward normal of every face of the original surface (NaN where degenerate).
    plane_levels : (F,) float64, mm
        Offset plane of every face: the points ``x`` with ``normals[f] . x == plane_levels[f]``.
    on_several : (V,) bool, optional
        Vertices that may lie on more planes than their face's (crease and corner points):
        a triangle with one is in the patch of any of its corners' planes that all three
        corners lie on.

    Returns
    -------
    Merged
    """
    n_faces = len(faces)
    if n_faces == 0:
        return Merged(vertices, faces, 0, 0)
    label = _plane_labels(vertices, vertex_face, normals, plane_levels)
    corner = label[faces]
    tri_label = np.where(
        (corner[:, 0] >= 0) & (corner[:, 0] == corner[:, 1]) & (corner[:, 0] == corner[:, 2]),
        corner[:, 0],
        -1,
    )
    if on_several is not None and on_several.any():
        _shared_planes(vertices, faces, label, on_several, normals, plane_levels, tri_label)
    for _ in range(UNTOUCH_ROUNDS):
        twin = twins(faces, len(vertices), tri_label)
        patch, seeds = patches(tri_label, twin)
        n_patches = len(seeds)
        loop_vertex, loop_start, loop_patch = boundary_loops(faces, twin, patch)
        touching = _touching(faces, patch, loop_vertex, loop_start, loop_patch, len(vertices))
        if not touching.any():
            break
        tri_label[touching] = -1
    patch_face = tri_label[seeds] // (2 * QUANTA + 1)
    chosen = _polygons(
        vertices, patch, n_patches, normals[patch_face], loop_vertex, loop_start, loop_patch
    )
    if chosen is None:
        return Merged(vertices, faces, 0, n_faces)
    new_faces, replaced = chosen
    keep = ~replaced[np.maximum(patch, 0)] | (patch < 0)
    out = np.concatenate([faces[keep], new_faces])
    used = np.zeros(len(vertices), dtype=bool)
    used[out] = True
    index = np.cumsum(used) - 1
    return Merged(
        np.ascontiguousarray(vertices[used]),
        np.ascontiguousarray(index[out], dtype=np.int64),
        int(replaced.sum()),
        n_faces,
    )


def _plane_labels(
    vertices: NDArray[np.float64],
    vertex_face: NDArray[np.int32],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Label every vertex; vertices within ``PLANE_TOLERANCE_MM`` of one plane share one.

    The plane is parallel to the vertex's face's offset plane: its offset from it, in
    whole ``PLANE_TOLERANCE_MM``, is part of the label (vertices held ``EDGE_MARGIN`` off a
    node lie on a plane just off the offset plane, all alike where the plane runs along
    the grid). -1 for a vertex farther than ``MAX_OFFSET_MM`` from its face's plane.
    """
    label = np.full(len(vertices), -1, dtype=np.int64)
    face = np.asarray(vertex_face, dtype=np.int64)
    candidate = np.flatnonzero(face >= 0)
    off = np.einsum("ij,ij->i", normals[face[candidate]], vertices[candidate])
    off -= plane_levels[face[candidate]]
    near = np.abs(off) <= MAX_OFFSET_MM
    candidate, off = candidate[near], off[near]
    quantum = np.rint(off / PLANE_TOLERANCE_MM).astype(np.int64) + QUANTA
    label[candidate] = face[candidate] * (2 * QUANTA + 1) + quantum
    return label


def _touching(
    faces: NDArray[np.int64],
    patch: NDArray[np.int64],
    loop_vertex: NDArray[np.int64],
    loop_start: NDArray[np.int64],
    loop_patch: NDArray[np.int64],
    n_vertices: int,
) -> NDArray[np.bool_]:
    """Return the triangles at a vertex where their patch's boundary touches itself.

    The patch's loops pass the vertex twice: not a simple polygon. (T,) bool.
    """
    entry_patch = np.repeat(loop_patch, np.diff(loop_start))
    key = entry_patch * np.int64(n_vertices) + loop_vertex
    unique, counts = np.unique(key, return_counts=True)
    twice = unique[counts > 1]
    if len(twice) == 0:
        return np.zeros(len(faces), dtype=bool)
    corner_key = np.where(patch[:, None] >= 0, patch[:, None] * np.int64(n_vertices) + faces, -1)
    touching: NDArray[np.bool_] = np.asarray(np.isin(corner_key, twice).any(axis=1), dtype=bool)
    return touching


def _shared_planes(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    label: NDArray[np.int64],
    on_several: NDArray[np.bool_],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    tri_label: NDArray[np.int64],
) -> None:
    """Label the triangles with a vertex on several planes by a plane all corners lie on.

    For each such triangle without a label, its corners' labels are tried in order; the
    first whose plane (with its offset in whole tolerances) every corner lies on labels it.
    `tri_label` is updated in place.
    """
    rows = np.flatnonzero((tri_label < 0) & on_several[faces].any(axis=1))
    for j in range(3):
        rows = rows[tri_label[rows] < 0]
        candidate = label[faces[rows, j]]
        rows, candidate = rows[candidate >= 0], candidate[candidate >= 0]
        face = candidate // (2 * QUANTA + 1)
        quantum = candidate % (2 * QUANTA + 1) - QUANTA
        level = plane_levels[face] + quantum * PLANE_TOLERANCE_MM
        corners = vertices[faces[rows]]
        off = np.einsum("ij,ikj->ik", normals[face], corners) - level[:, None]
        on = (np.abs(off) <= 0.5 * PLANE_TOLERANCE_MM).all(axis=1)
        tri_label[rows[on]] = candidate[on]


def _polygons(
    vertices: NDArray[np.float64],
    patch: NDArray[np.int64],
    n_patches: int,
    normal: NDArray[np.float64],
    loop_vertex: NDArray[np.int64],
    loop_start: NDArray[np.int64],
    loop_patch: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.bool_]] | None:
    """Triangulate the patches with interior vertices again.

    Returns the new triangles and which patches they replace ((P,) bool), or None when
    none is replaced.
    """
    n_loops = len(loop_patch)
    if n_loops == 0:
        return None
    loop_size = np.diff(loop_start)
    entry_loop = np.repeat(np.arange(n_loops), loop_size)
    entry_patch = loop_patch[entry_loop]
    n_entries = len(loop_vertex)
    ok = np.ones(n_patches, dtype=bool)
    # A vertex twice on one patch's boundary: the loops touch (not a simple polygon).
    key = entry_patch * len(vertices) + loop_vertex
    order = np.argsort(key, kind="stable")
    twice = key[order][1:] == key[order][:-1]
    ok[entry_patch[order][1:][twice]] = False
    # Patch frames: a basis (u, w) of the plane with u x w the outward normal.
    axis = np.zeros_like(normal)
    axis[np.arange(n_patches), np.argmin(np.abs(normal), axis=1)] = 1.0
    u = np.cross(normal, axis)
    u /= np.linalg.norm(u, axis=1)[:, None]
    w = np.cross(normal, u)
    first = np.full(n_patches, -1, dtype=np.int64)
    first[loop_patch[::-1]] = loop_vertex[loop_start[:-1][::-1]]
    rel = vertices[loop_vertex] - vertices[first[entry_patch]]
    x2 = np.einsum("ij,ij->i", rel, u[entry_patch])
    y2 = np.einsum("ij,ij->i", rel, w[entry_patch])
    # Signed area of every loop (shoelace, the loop closed on itself).
    nxt = np.arange(1, n_entries + 1)
    nxt[loop_start[1:] - 1] = loop_start[:-1]
    cross = x2 * y2[nxt] - x2[nxt] * y2
    loop_area = 0.5 * np.add.reduceat(cross, loop_start[:-1])
    positive = np.bincount(loop_patch, weights=loop_area > 0, minlength=n_patches)
    ok &= positive == 1
    n_holes = np.bincount(loop_patch, minlength=n_patches) - 1
    n_boundary = np.bincount(entry_patch, minlength=n_patches)
    n_tris = np.bincount(patch[patch >= 0], minlength=n_patches)
    expected = n_boundary + 2 * n_holes - 2
    ok &= n_tris > expected
    chosen = np.flatnonzero(ok)
    if len(chosen) == 0:
        return None
    # Rings of the chosen patches, each outer ring first, closed on their first point.
    take = ok[loop_patch]
    loops = np.flatnonzero(take)
    loops = loops[np.lexsort((loop_area[loops] <= 0, loop_patch[loops]))]
    sizes = loop_size[loops]
    starts = loop_start[loops]
    ring_entries = _ring_entries(starts, sizes)
    coords = np.column_stack([x2[ring_entries], y2[ring_entries]])
    ring_offsets = np.concatenate([[0], np.cumsum(sizes + 1)])
    polygon_rings = np.bincount(loop_patch[loops], minlength=n_patches)[chosen]
    polygon_offsets = np.concatenate([[0], np.cumsum(polygon_rings)])
    polygons = shapely.from_ragged_array(
        shapely.GeometryType.POLYGON, coords, (ring_offsets, polygon_offsets)
    )
    valid = shapely.is_valid(polygons)
    ok[chosen[~valid]] = False
    polygons, chosen = polygons[valid], chosen[valid]
    if len(chosen) == 0:
        return None
    triangles = shapely.constrained_delaunay_triangles(polygons)
    # Every triangle is a closed ring of four points.
    points, owner = shapely.get_coordinates(triangles, return_index=True)
    tri_patch = chosen[owner[::4]]
    ring = points.reshape(-1, 4, 2)[:, :3]
    # Corners back to boundary entries: exact coordinates within the patch.
    entry_of = _entries_at(
        entry_patch, x2, y2, np.repeat(tri_patch, 3), ring[:, :, 0].ravel(), ring[:, :, 1].ravel()
    ).reshape(-1, 3)
    bad = np.zeros(n_patches, dtype=bool)
    bad[tri_patch[(entry_of < 0).any(axis=1)]] = True
    entry_of = np.maximum(entry_of, 0)
    area = 0.5 * (
        (x2[entry_of[:, 1]] - x2[entry_of[:, 0]]) * (y2[entry_of[:, 2]] - y2[entry_of[:, 0]])
        - (x2[entry_of[:, 2]] - x2[entry_of[:, 0]]) * (y2[entry_of[:, 1]] - y2[entry_of[:, 0]])
    )
    flip = area < 0
    entry_of[flip] = entry_of[flip][:, ::-1]
    area = np.abs(area)
    bad[tri_patch[area <= 0]] = True
    total = np.bincount(loop_patch, weights=loop_area, minlength=n_patches)
    made = np.bincount(tri_patch, weights=area, minlength=n_patches)
    wrong = np.abs(made[chosen] - total[chosen]) > AREA_TOLERANCE * np.abs(total[chosen])
    bad[chosen[wrong]] = True
    bad |= _edges_differ(entry_of, tri_patch, entry_patch, nxt, n_entries, n_patches)
    ok[bad] = False
    use = ok[tri_patch]
    if not use.any():
        return None
    new_faces = loop_vertex[entry_of[use]]
    return new_faces, ok


def _ring_entries(starts: NDArray[np.int64], sizes: NDArray[np.int64]) -> NDArray[np.int64]:
    """Entries of every ring, its first entry repeated at its end."""
    lengths = sizes + 1
    ring = np.repeat(np.arange(len(starts)), lengths)
    position = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    position = np.where(position == np.repeat(sizes, lengths), 0, position)
    entries: NDArray[np.int64] = starts[ring] + position
    return entries


def _entries_at(
    entry_patch: NDArray[np.int64],
    x2: NDArray[np.float64],
    y2: NDArray[np.float64],
    query_patch: NDArray[np.int64],
    qx: NDArray[np.float64],
    qy: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Boundary entry with the query's patch and exact coordinates, -1 for none."""
    order = np.lexsort((y2, x2, entry_patch))
    found: NDArray[np.int64] = _search(
        entry_patch[order], x2[order], y2[order], order, query_patch, qx, qy
    )
    return found


@kernel
def _search(
    patch: NDArray[np.int64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    order: NDArray[np.int64],
    query_patch: NDArray[np.int64],
    qx: NDArray[np.float64],
    qy: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Binary search of ``(patch, x, y)`` rows sorted in that order; ``order[row]`` or -1."""
    out = np.full(len(qx), -1, dtype=np.int64)
    for q in range(len(qx)):
        lo, hi = 0, len(x)
        key = (query_patch[q], qx[q], qy[q])
        while lo < hi:
            mid = (lo + hi) // 2
            if (patch[mid], x[mid], y[mid]) < key:
                lo = mid + 1
            else:
                hi = mid
        if lo < len(x) and patch[lo] == key[0] and x[lo] == key[1] and y[lo] == key[2]:
            out[q] = order[lo]
    return out


@kernel
def _edges_differ(
    entry_of: NDArray[np.int64],
    tri_patch: NDArray[np.int64],
    entry_patch: NDArray[np.int64],
    nxt: NDArray[np.int64],
    n_entries: int,
    n_patches: int,
) -> NDArray[np.bool_]:
    """Patches whose new triangles' unpaired edges are not exactly their boundary.

    Every directed edge between entries (their patch's) is used once; one without its
    reverse is a boundary edge ``i -> nxt[i]``, and every boundary edge of a patch with
    new triangles is one of them, without its reverse. (P,) bool.
    """
    start = np.zeros(n_entries + 1, dtype=np.int64)
    has_triangles = np.zeros(n_patches, dtype=np.bool_)
    for t in range(len(entry_of)):
        has_triangles[tri_patch[t]] = True
        for i in range(3):
            start[entry_of[t, i] + 1] += 1
    for a in range(n_entries):
        start[a + 1] += start[a]
    end = np.empty(start[n_entries], dtype=np.int64)
    fill = start[:-1].copy()
    for t in range(len(entry_of)):
        for i in range(3):
            a = entry_of[t, i]
            end[fill[a]] = entry_of[t, (i + 1) % 3]
            fill[a] += 1
    bad = np.zeros(n_patches, dtype=np.bool_)
    for a in range(n_entries):
        p = entry_patch[a]
        boundary_seen = False
        for j in range(start[a], start[a + 1]):
            b = end[j]
            for q in range(start[a], j):
                if end[q] == b:
                    bad[p] = True  # the edge twice
            paired = False
            for q in range(start[b], start[b + 1]):
                if end[q] == a:
                    paired = True
                    break
            if b == nxt[a]:
                boundary_seen = True
                if paired:
                    bad[p] = True  # a boundary edge inside
            elif not paired:
                bad[p] = True  # an open edge off the boundary
        if has_triangles[p] and not boundary_seen:
            bad[p] = True  # a boundary edge missing
    return bad
