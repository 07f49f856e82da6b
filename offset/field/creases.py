"""Sharp creases and corners of a marched layer surface, put back where the field has them.

Inside a part, a layer's surface is made of pieces of the faces' offset planes (where a
point's nearest point lies inside its nearest face), of cylinders and of spheres. Where two
planes meet at a convex crease of the part (the layer is the intersection of the two half
spaces behind them), the surface has a sharp edge along their line; a marched surface,
whose vertices lie on the grid's edges, cuts that edge off with a strip of chamfer
triangles, up to about half a grid step wide. :func:`sharpen_creases` puts the edge back:

- every mesh edge between a vertex on plane ``A`` and one on plane ``B`` (their nearest
  faces, :func:`shellvox.offset.field.node_field.edge_crossing`), the vertices each
  behind the other's plane, is split where it crosses the planes' bisector, and the new
  vertex is moved onto the planes' line (at most the edge's length);
- a triangle whose three edges are split (its corners on three planes) gets the three
  planes' common point as a seventh vertex;
- every new triangle then has its corners on one plane.

A split is kept where its crease point's nearest point on both faces lies inside them (on
the faces' offset planes, so on the layer's surface where no third face is nearer), its
move is at least ``MIN_MOVE_MM`` and every new triangle keeps its parent's side (its
normal less than 90 degrees from the parent's; otherwise the triangle's splits are
dropped and the rest tried again).

This is the feature step of Kobbelt et al.'s extended marching cubes [1]_ with the exact
planes of Ju et al.'s dual contouring of Hermite data [2]_, applied to the marched
triangles: the vertices go onto the features, not the cells.

References
----------
.. [1] L. Kobbelt, M. Botsch, U. Schwanecke, H.-P. Seidel, "Feature sensitive surface
   extraction from volume data", SIGGRAPH 2001.
.. [2] T. Ju, F. Losasso, S. Schaefer, J. Warren, "Dual contouring of Hermite data",
   SIGGRAPH 2002.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.field.crease_edits import apply_snaps, snap_targets, split_triangles
from shellvox.offset.field.crease_geometry import (
    crease_candidates,
    edge_corner_points,
    edge_crease_points,
    plane_labels,
    triangle_corners,
)
from shellvox.offset.field.patch_topology import at_vertices, fans, twins
from shellvox.voxel.geometry._nearest import SurfaceIndex, nearest_on_surface

#: Largest difference (mm) between a crease or corner point's distance to the part and
#: the depth of its planes' faces: the point lies on the layer's surface.
ON_SURFACE_MM = 1e-8

#: Passes of splitting (a crease point lies on two planes, so a later pass may split its
#: edges to a third).
PASSES = 4

#: New points closer than this (mm) to another point become one vertex with it.
JOIN_MM = 1e-9

#: Height (mm) under which a triangle is one of the slivers the grid leaves around its
#: nodes and edges that lie exactly on the surface (their vertices held ``EDGE_MARGIN``
#: of an edge off the nodes).
THIN_MM = 1e-6

#: Tries of the whole surface; a try that makes triangles cross leaves the surface as
#: marched around them for the next.
CHECKS = 4

#: Rounds of dropping the splits of triangles that would turn over.
ROUNDS = 16

#: Triangles the splitting rounds of a surface may visit in all, per triangle of the
#: surface as marched (each round visits the triangles at the crease candidates). A part
#: of many facets can end every pass with its rounds run out and nothing kept, passes
#: and tries over: the passes stop when this is spent, what they made so far goes
#: through the crossing check, and the surface stays as marched where that fails.
WORK = 4.0

#: Triangles the splitting rounds of a surface may visit in all at least: a small sharp
#: part (a few mm, most of its surface at a crease) visits several times its triangles.
MIN_WORK = 2_000_000


class _Work:
    """Triangles the splitting rounds may still visit (:data:`WORK`)."""

    def __init__(self, triangles: int) -> None:
        self.left = triangles

    def take(self, triangles: int) -> bool:
        """Spend `triangles`; False, and nothing left, when fewer are left."""
        if triangles > self.left:
            self.left = 0
            return False
        self.left -= triangles
        return True


class Creases(NamedTuple):
    """A marched surface with its creases and corners put back.

    Attributes
    ----------
    vertices : (V', 3) float64, mm
        The surface's vertices, then the new ones.
    faces : (T', 3) int64
        Outward-oriented triangles (the unsplit ones first, in their order).
    vertex_face : (V',) int32
        A face whose offset plane every vertex lies on, -1 for none (a new vertex lies on
        two or three planes; one of their faces).
    on_crease : (V',) bool
        The new vertices.
    split_edges : int
    corners : int
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    vertex_face: NDArray[np.int32]
    on_crease: NDArray[np.bool_]
    split_edges: int
    corners: int


def sharpen_creases(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    vertex_face: NDArray[np.int32],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
    surface: SurfaceIndex,
) -> Creases:
    """Put back the sharp creases and corners a marched layer surface cut off.

    The splitting rounds of all passes and tries visit at most ``WORK`` triangles per
    triangle of the surface (``MIN_WORK`` at least): their time follows the surface's
    size.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (T, 3) int64
        A closed, 2-manifold, outward-oriented layer surface.
    vertex_face : (V,) int32
        The face whose offset plane each vertex lies on (its nearest face), -1 for none.
    normals : (F, 3) float64
        Unit outward normal of every face (NaN where degenerate).
    plane_levels : (F,) float64, mm
        The layer's offset plane of every face: ``normals[f] . x == plane_levels[f]``.
    depth_mm : (F,) float64, mm
        The layer's depth of every face.
    surface : SurfaceIndex
        The part's surface (the faces ``vertex_face`` names), for the exact distance of
        every crease and corner point.

    Returns
    -------
    Creases
    """
    n_vertices = len(vertices)
    label = plane_labels(vertices, vertex_face, normals, plane_levels)
    unchanged = Creases(vertices, faces, vertex_face, np.zeros(n_vertices, dtype=bool), 0, 0)
    work = _Work(max(int(WORK * len(faces)), MIN_WORK))
    for _ in range(CHECKS):
        out, crossing = _sharpen(vertices, faces, vertex_face, label, normals, plane_levels,
                                 depth_mm, surface, work)  # fmt: skip
        if len(crossing) == 0:
            return unchanged if out is None else out
        if work.left == 0:
            break
        # Leave the surface as marched around the crossings (a vertex ring further).
        at = np.zeros(len(vertices), dtype=bool)
        at[crossing] = True
        label[faces[at_vertices(faces, at)].ravel()] = -1
    return unchanged


def _sharpen(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    vertex_face: NDArray[np.int32],
    label: NDArray[np.int64],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
    surface: SurfaceIndex,
    work: _Work,
) -> tuple[Creases | None, NDArray[np.int64]]:
    """One try of :func:`sharpen_creases` with the vertices' planes `label` (-1: none).

    Returns the surface (None where nothing changed) and the input's vertices of the
    triangles that cross (the candidates' triangles and every triangle at their vertices,
    each pair tested, new and old).
    """
    n_vertices = len(vertices)
    candidate = np.flatnonzero(crease_candidates(faces, label, normals))
    none = np.zeros(0, dtype=np.int64)
    if len(candidate) == 0:
        return None, none
    # The candidates and every triangle at their vertices as a mesh of their own (local
    # vertex ids, up to three planes a vertex); only the candidates' vertices, all of
    # whose triangles are here, may move.
    inner = np.zeros(n_vertices, dtype=bool)
    inner[faces[candidate].ravel()] = True
    candidate = np.flatnonzero(at_vertices(faces, inner))
    kept_ids, local = np.unique(faces[candidate], return_inverse=True)
    tri = local.reshape(-1, 3).astype(np.int64)
    points = vertices[kept_ids]
    planes = np.full((len(kept_ids), 3), -1, dtype=np.int64)
    planes[:, 0] = label[kept_ids]
    split_edges = corners = 0
    fixed = ~inner[kept_ids]
    stuck = np.zeros(len(points), dtype=bool)
    for _ in range(PASSES):
        step = _one_pass(
            tri, points, planes, stuck, fixed, normals, plane_levels, depth_mm, surface, work
        )
        if step is None:
            break
        tri, points, planes, stuck, n_split, n_corners = step
        fixed = np.concatenate([fixed, np.zeros(len(points) - len(fixed), dtype=bool)])
        split_edges += n_split
        corners += n_corners
        if work.left == 0:
            break
    n_old = len(kept_ids)
    moved = (points[:n_old] != vertices[kept_ids]).any(axis=1)
    n_new = len(points) - n_old
    if n_new == 0 and not moved.any():
        return None, none
    pairs = intersecting_pairs(points, tri)
    # Not with the slivers around nodes on the surface (within EDGE_MARGIN of an edge of
    # the grid that lies on the surface, which the crease runs along).
    corner = points[tri[pairs.ravel()]]
    doubled = np.linalg.norm(
        np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]), axis=1
    )
    longest = np.linalg.norm(corner - corner[:, [1, 2, 0]], axis=2).max(axis=1)
    height = doubled / np.maximum(longest, 1e-300)
    pairs = pairs[(height.reshape(-1, 2) > THIN_MM).all(axis=1)]
    if len(pairs):
        crossing = np.unique(tri[pairs.ravel()])
        return None, kept_ids[crossing[crossing < n_old]]
    to_global = np.concatenate([kept_ids, n_vertices + np.arange(n_new)])
    changed = np.zeros(len(faces), dtype=bool)
    changed[candidate] = True
    out_vertices = np.concatenate([vertices, points[n_old:]])
    out_vertices[kept_ids] = points[:n_old]  # the vertices moved onto a crease
    n_kept = len(faces) - len(candidate)
    out_faces = np.empty((n_kept + len(tri), 3), dtype=np.int64)
    np.compress(~changed, faces, axis=0, out=out_faces[:n_kept])
    out_faces[n_kept:] = to_global[tri]
    region = np.zeros(len(out_vertices), dtype=bool)
    region[kept_ids] = True
    region[n_vertices:] = True
    pinch = _pinches(out_vertices, out_faces, region)
    if pinch.any():
        at = tri[pinch[to_global[tri]].any(axis=1)].ravel()
        return None, kept_ids[np.unique(at[at < n_old])]
    on_crease = np.zeros(n_vertices + n_new, dtype=bool)
    on_crease[n_vertices:] = True
    on_crease[kept_ids] = planes[:n_old, 1] >= 0
    return (
        Creases(
            out_vertices,
            out_faces,
            np.concatenate(
                [np.asarray(vertex_face, dtype=np.int32), planes[n_old:, 0].astype(np.int32)]
            ),
            on_crease,
            split_edges,
            corners,
        ),
        none,
    )


def _pinches(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], region: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """Return the `region`'s vertices where the surface pinches. (V,) bool.

    A pinch is a vertex with two fans of triangles (the surface touches itself there:
    Manifold splits it into two vertices at one position, which no simplification joins
    again), or vertices at one position not joined by a chain of edges under ``THIN_MM``
    (the grid's clusters at nodes on the surface are joined so, and simplifying collapses
    them).
    """
    near = faces[at_vertices(faces, region)]
    ids, local = np.unique(near, return_inverse=True)
    local = local.reshape(-1, 3).astype(np.int64)
    count = fans(local, twins(local, len(ids), np.zeros(len(local), dtype=np.int64)), len(ids))
    pinched = count > 1
    _, place, copies = np.unique(vertices[ids], axis=0, return_inverse=True, return_counts=True)
    place = place.ravel()
    shared = copies[place] > 1
    if shared.any():
        # the vertices at one place, joined by chains of edges under THIN_MM
        a, b = local.ravel(), local[:, [1, 2, 0]].ravel()
        points = vertices[ids]
        zero = np.linalg.norm(points[a] - points[b], axis=1) <= THIN_MM
        graph = scipy.sparse.coo_matrix(
            (np.ones(int(zero.sum())), (a[zero], b[zero])), shape=(len(ids), len(ids))
        )
        _, part = scipy.sparse.csgraph.connected_components(graph, directed=False)
        groups = np.unique(np.column_stack([place[shared], part[shared]]), axis=0)
        split = np.bincount(groups[:, 0], minlength=len(copies)) > 1
        pinched |= split[place]
    out = np.zeros(len(vertices), dtype=bool)
    out[ids[pinched & region[ids]]] = True
    return out


def _one_pass(
    tri: NDArray[np.int64],
    points: NDArray[np.float64],
    planes: NDArray[np.int64],
    stuck: NDArray[np.bool_],
    fixed: NDArray[np.bool_],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
    surface: SurfaceIndex,
    work: _Work,
) -> (
    tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_], int, int]
    | None
):
    """Split the edges of a mesh whose crease points lie on the layer's surface, once.

    First the vertices next to a crease move onto it (:func:`_snap`; a `stuck` vertex, one
    of a triangle whose splits would turn it over, from up to a whole edge away; a `fixed`
    one, with triangles outside the mesh, stays). Returns
    the new triangles, points (the old ones first), planes and stuck vertices, the edges
    split and the corners added; None if nothing changed.
    """
    snapped = _snap(tri, points, planes, stuck, fixed, normals, plane_levels, depth_mm, surface)
    unchanged = (tri, points, planes, np.zeros(len(points), dtype=bool), 0, 0)
    n_points = len(points)
    lo = np.minimum(tri, tri[:, [1, 2, 0]])
    hi = np.maximum(tri, tri[:, [1, 2, 0]])
    unique, edge_of, count = np.unique(
        (lo * np.int64(n_points) + hi).ravel(), return_inverse=True, return_counts=True
    )
    edge_of = edge_of.reshape(-1, 3).astype(np.int64)
    ends = np.column_stack([unique // n_points, unique % n_points])
    # Up to four plane pairs per edge (two planes per end); the first on the surface counts.
    pair = np.stack(
        [
            np.column_stack([planes[ends[:, 0], a], planes[ends[:, 1], b]])
            for a in (0, 1)
            for b in (0, 1)
        ],
        axis=1,
    )
    pair[(count != 2)] = -1  # an edge of the whole surface lies in two triangles here
    point, valid = edge_crease_points(ends, points, pair, normals, plane_levels)
    edge_point, two, ok, nearer, near_pair = _first_on_surface(
        point, pair, valid, depth_mm, surface
    )
    edge_planes = np.column_stack([two, np.full(len(two), -1)])
    # A third plane G at an edge (its crease point is nearer to G's face, or the edge's
    # crease point on another pair of planes lies on the surface too): the edge passes
    # the corner of the two planes and G's, or crosses G's plane first (the line of A
    # and G, or of G and B).
    at_corner = np.flatnonzero(nearer >= 0)
    if len(at_corner):
        first, second, third = near_pair[at_corner, 0], near_pair[at_corner, 1], nearer[at_corner]
        triple = np.column_stack([first, second, third])
        corner3, corner_valid = edge_corner_points(
            ends[at_corner], points, triple, normals, plane_levels
        )
        on3, _ = _on_surface(surface, corner3, depth_mm[first], depth_mm)
        take = corner_valid & on3
        edge_point[at_corner[take]] = corner3[take]
        edge_planes[at_corner[take]] = triple[take]
        ok[at_corner[take]] = True
    retry = np.flatnonzero(~ok & (nearer >= 0))
    if len(retry):
        first, second, third = near_pair[retry, 0], near_pair[retry, 1], nearer[retry]
        via = np.stack([np.column_stack([first, third]), np.column_stack([third, second])], axis=1)
        point2, valid2 = edge_crease_points(ends[retry], points, via, normals, plane_levels)
        p2, planes2, ok2, _, _ = _first_on_surface(point2, via, valid2, depth_mm, surface)
        edge_point[retry[ok2]] = p2[ok2]
        edge_planes[retry[ok2], :2] = planes2[ok2]
        ok[retry[ok2]] = True
    corner, corner_planes, corner_ok = triangle_corners(tri, points, planes, normals, plane_levels)
    has = corner_ok.copy()
    corner_ok[has] = _on_surface(surface, corner[has], depth_mm[corner_planes[has, 0]], depth_mm)[0]
    if not (ok.any() or corner_ok.any()):
        return unchanged if snapped else None
    # Edges at one corner get its point each: one point for them all.
    rep = np.arange(len(edge_point))
    split = np.flatnonzero(ok)
    _, first_at, same = np.unique(edge_point[split], axis=0, return_index=True, return_inverse=True)
    rep[split] = split[first_at[same.ravel()]]
    rejected = np.zeros(len(tri), dtype=bool)
    for _ in range(ROUNDS):
        if not work.take(len(tri)):  # spent: as if the rounds ran out
            return unchanged if snapped else None
        new_faces, has_corner, bad, merge = split_triangles(
            tri, edge_of, edge_point, ok, corner, corner_ok, points, n_points,
            planes, edge_planes, corner_planes, normals, rep,
        )  # fmt: skip
        if merge.any():
            _merge_points(merge, tri, edge_of, ok, rep, edge_point)
            continue
        if not bad.any():
            break
        # a turned-over fan loses its corner point first, then the triangle its splits
        corner_ok[bad & has_corner] = False
        ok[edge_of[bad & ~has_corner].ravel()] = False
        rejected |= bad & ~has_corner
    else:
        return unchanged if snapped else None
    changed = ok[edge_of].any(axis=1) | has_corner
    now_stuck = np.zeros(len(points), dtype=bool)
    now_stuck[tri[rejected & ~changed].ravel()] = True
    if not changed.any():
        if snapped or (now_stuck & ~stuck).any():
            return (tri, points, planes, now_stuck, 0, 0)
        return None
    new_points = np.concatenate([edge_point, corner])
    new_planes = np.concatenate([edge_planes, corner_planes])
    used = np.zeros(len(new_points), dtype=bool)
    is_new = new_faces >= n_points
    used[new_faces[is_new] - n_points] = True
    renumber = np.cumsum(used) - 1 + n_points
    new_faces[is_new] = renumber[new_faces[is_new] - n_points]
    all_tri = np.concatenate([tri[~changed], new_faces])
    all_points = np.concatenate([points, new_points[used]])
    all_planes = np.concatenate([planes, new_planes[used]])
    joined = _join_coincident(all_tri, all_points, n_points)
    if joined is None or (len(joined) == len(tri) and (joined < n_points).all()):
        return unchanged if snapped else None  # nothing new stays
    return (
        joined,
        all_points,
        all_planes,
        np.concatenate([now_stuck, np.zeros(int(used.sum()), dtype=bool)]),
        int(ok.sum()),
        int(has_corner.sum()),
    )


def _join_coincident(
    tri: NDArray[np.int64], points: NDArray[np.float64], n_old: int
) -> NDArray[np.int64] | None:
    """Make every new point within ``JOIN_MM`` of another point one vertex with it.

    A corner reached from several edges and triangles is one point; the triangles that
    vanish go.

    A triangle with two corners at one vertex goes, and so do two triangles on the same
    three vertices facing each other (a fin). Returns the triangles, or None where the
    mesh would not stay edge-manifold (every edge in at most two triangles, one each
    way).
    """
    if len(points) == n_old:
        return tri
    near = cKDTree(points).sparse_distance_matrix(
        cKDTree(points[n_old:]), JOIN_MM, output_type="coo_matrix"
    )
    a, b = near.row, near.col + n_old
    keep_pair = a != b
    if not keep_pair.any():
        return tri
    graph = scipy.sparse.coo_matrix(
        (np.ones(int(keep_pair.sum())), (a[keep_pair], b[keep_pair])),
        shape=(len(points), len(points)),
    )
    _, group = scipy.sparse.csgraph.connected_components(graph, directed=False)
    first = np.full(len(points), len(points), dtype=np.int64)
    np.minimum.at(first, group, np.arange(len(points)))
    into = first[group]
    moved = into != np.arange(len(points))
    touched = np.flatnonzero((moved[tri] | moved[into[tri]]).any(axis=1))
    joined = into[tri[touched]]
    keep = (joined[:, 0] != joined[:, 1]) & (joined[:, 1] != joined[:, 2])
    keep &= joined[:, 2] != joined[:, 0]
    joined = joined[keep]
    _, row_group, counts = np.unique(
        np.sort(joined, axis=1), axis=0, return_inverse=True, return_counts=True
    )
    if (counts > 2).any():
        return None
    joined = joined[counts[row_group.ravel()] == 1]  # fins go
    out = np.concatenate([np.delete(tri, touched, axis=0), joined])
    ring = out[np.isin(out, np.unique(into[moved])).any(axis=1)]  # the triangles at a joined vertex
    n = np.int64(len(points))
    directed = ring.ravel() * n + ring[:, [1, 2, 0]].ravel()
    if np.unique(directed).size != directed.size:
        return None
    return out


def _snap(
    tri: NDArray[np.int64],
    points: NDArray[np.float64],
    planes: NDArray[np.int64],
    stuck: NDArray[np.bool_],
    fixed: NDArray[np.bool_],
    normals: NDArray[np.float64],
    plane_levels: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
    surface: SurfaceIndex,
) -> int:
    """Move the vertices next to a crease onto it; `points` and `planes` change in place.

    A vertex on plane ``B`` with an edge to a vertex on plane ``A`` (a convex crease) whose
    nearest point on the planes' line is within ``SNAP_SHARE`` of that edge's length goes
    there (splitting its edges would leave slivers), where that point lies on the layer's
    surface and none of its triangles turns over or loses most of its area. No two
    vertices of one triangle move in one pass. Returns the vertices moved.
    """
    target, other, move = snap_targets(tri, points, planes, stuck, normals, plane_levels)
    candidate = np.flatnonzero(np.isfinite(move) & ~fixed)
    if len(candidate) == 0:
        return 0
    on, _ = _on_surface(surface, target[candidate], depth_mm[planes[candidate, 0]], depth_mm)
    candidate = candidate[on]
    if len(candidate) == 0:
        return 0
    order = candidate[np.argsort(move[candidate], kind="stable")]
    corner_of = np.argsort(tri.ravel(), kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(tri.ravel(), minlength=len(points)))])
    moved: int = apply_snaps(
        tri, points, planes, order, target, other, corner_of // 3, start, normals
    )
    return moved


def _merge_points(
    merge: NDArray[np.bool_],
    tri: NDArray[np.int64],
    edge_of: NDArray[np.int64],
    ok: NDArray[np.bool_],
    rep: NDArray[np.int64],
    edge_point: NDArray[np.float64],
) -> None:
    """Merge the two crease points of every triangle in `merge`.

    The point is their midpoint, on their common line; `rep` and `edge_point` change in
    place.
    """
    for t in np.flatnonzero(merge):
        split = edge_of[t][ok[edge_of[t]]]
        roots = []
        for e in split:
            while rep[e] != e:
                e = rep[e]
            roots.append(int(e))
        first, second = roots[0], roots[1]
        if first != second:
            edge_point[first] = 0.5 * (edge_point[first] + edge_point[second])
            rep[second] = first
    # every edge straight to its root (pointer jumping)
    while (rep[rep] != rep).any():
        rep[:] = rep[rep]


def _first_on_surface(
    point: NDArray[np.float64],
    pair: NDArray[np.int64],
    valid: NDArray[np.bool_],
    depth_mm: NDArray[np.float64],
    surface: SurfaceIndex,
) -> tuple[
    NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_], NDArray[np.int64], NDArray[np.int64]
]:
    """Return the first valid candidate of every edge that lies on the layer's surface.

    Returns its point (E, 3), its planes (E, 2), whether there is one (E,), and, for the
    others, the face nearer than the planes' to their first valid candidate (-1 for none)
    and that candidate's planes (E, 2).
    """
    n = len(point)
    rows, combos = np.nonzero(valid)
    on, face = _on_surface(surface, point[rows, combos], depth_mm[pair[rows, combos, 0]], depth_mm)
    found = np.full(n, -1, dtype=np.int64)
    found[rows[on][::-1]] = combos[on][::-1]  # the first combination that holds
    ok = found >= 0
    nearer = np.full(n, -1, dtype=np.int64)
    first_valid = np.zeros(n, dtype=np.int64)
    nearer[rows[::-1]] = face[::-1]
    first_valid[rows[::-1]] = combos[::-1]
    nearer[ok] = -1
    pick = np.maximum(found, 0)
    every = np.arange(n)
    chosen = pair[every, pick]
    # Another candidate on the surface with a third plane: the edge passes a corner.
    third = pair[rows[on], combos[on]]
    row_on = rows[on]
    for column in (0, 1):
        plane = third[:, column]
        extra = (plane != chosen[row_on, 0]) & (plane != chosen[row_on, 1])
        nearer[row_on[extra]] = plane[extra]
    return (
        point[every, pick],
        chosen,
        ok,
        nearer,
        np.where(ok[:, None], chosen, pair[every, first_valid]),
    )


def _on_surface(
    surface: SurfaceIndex,
    points: NDArray[np.float64],
    depth: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
) -> tuple[NDArray[np.bool_], NDArray[np.int64]]:
    """Return whether each point lies on the layer's surface, and a nearer face.

    A point lies on it where its exact distance to the part is `depth` (its planes' faces'
    depth) and so is its nearest face's depth; where it does not, its nearest face if that
    is nearer (else -1). (P,) each.
    """
    if len(points) == 0:
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=np.int64)
    near = nearest_on_surface(surface, points)
    on: NDArray[np.bool_] = (np.abs(near.distance_mm - depth) <= ON_SURFACE_MM) & (
        np.abs(depth_mm[near.face_ids] - depth) <= ON_SURFACE_MM
    )
    nearer = np.where(~on & (near.distance_mm < depth), near.face_ids, -1).astype(np.int64)
    return on, nearer
