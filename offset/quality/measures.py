"""Quality numbers of one shell against its original surface and the previous shell."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
import trimesh

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import bend_angles, edge_adjacency, face_normals, smallest_angles
from shellvox.offset.crossing.intersections import count_self_intersections, intersecting_pairs
from shellvox.voxel.geometry._nearest import SurfaceIndex, nearest_on_surface, winding_numbers

#: Barycentric coordinate below which a closest point counts as on an edge / vertex.
FEATURE_BARY = 1e-6


def percentiles(values: FloatArray) -> dict[str, float | None]:
    """Return p50, p99 and max of `values` as plain floats (``None`` when empty).

    Parameters
    ----------
    values : (N,) float64

    Returns
    -------
    dict
        Keys ``p50``, ``p99``, ``max``.
    """
    if values.size == 0:
        return {"p50": None, "p99": None, "max": None}
    p50, p99 = np.percentile(values, [50, 99])
    return {"p50": float(p50), "p99": float(p99), "max": float(values.max())}


def nearest_feature(
    original: trimesh.Trimesh, points: FloatArray
) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
    """Return exact closest points on `original` and the feature kind they lie on.

    Parameters
    ----------
    original : trimesh.Trimesh
    points : (N, 3) float64, mm

    Returns
    -------
    closest : (N, 3) float64, mm
    distance : (N,) float64, mm
    face : (N,) int64
        Triangle holding the closest point.
    kind : (N,) int64
        0 face interior, 1 edge, 2 vertex.
    """
    index = SurfaceIndex.build(original.vertices, original.faces)
    hit = nearest_on_surface(index, points)
    triangles = index.vertices[index.faces[hit.face_ids]]
    closest = np.einsum("nc,nck->nk", hit.barycentric, triangles)
    kind = (hit.barycentric < FEATURE_BARY).sum(axis=1).astype(np.int64)
    return closest, hit.distance_mm, hit.face_ids, kind


def equidistance(
    original: trimesh.Trimesh, depth: FloatArray, points: FloatArray
) -> dict[str, Any]:
    """Return equidistance and plane-deviation statistics of points on a shell.

    Parameters
    ----------
    original : trimesh.Trimesh
        The original closed surface.
    depth : (F,) float64, mm
        Requested cumulative depth per original face.
    points : (N, 3) float64, mm
        Points sampled on the shell.

    Returns
    -------
    dict
        ``error_pct`` (p50/p99/max of ``|dist - D(nearest)| / D(nearest)`` in %),
        ``plane_deviation_mm`` (the same in mm for points whose nearest point is inside a
        face, i.e. their distance from the moved face plane), and ``by_region``: the same
        percent statistics and the sample share for points nearest to a face interior, a
        convex edge, a reflex edge and a vertex. ``worst`` names the sample of largest
        error: ``point_mm`` (on the shell), ``nearest_mm`` (on the surface), ``region``
        and ``error_pct``.
    """
    closest, distance, face, kind = nearest_feature(original, points)
    want = depth[face]
    err_mm = np.abs(distance - want)
    err_pct = 100.0 * err_mm / want
    region = np.where(kind == 0, "face", np.where(kind >= 2, "vertex", "edge")).astype(object)
    if np.any(kind == 1):
        region[kind == 1] = _edge_kind(original, points[kind == 1], face[kind == 1])
    by_region = {
        name: {"share": float(np.mean(region == name)), **percentiles(err_pct[region == name])}
        for name in ("face", "convex_edge", "reflex_edge", "vertex")
    }
    worst = int(np.argmax(err_pct))
    return {
        "n_samples": int(points.shape[0]),
        "error_pct": percentiles(err_pct),
        "plane_deviation_mm": percentiles(err_mm[kind == 0]),
        "by_region": by_region,
        "worst": {
            "point_mm": [float(x) for x in points[worst]],
            "nearest_mm": [float(x) for x in closest[worst]],
            "region": str(region[worst]),
            "error_pct": float(err_pct[worst]),
        },
    }


def _edge_kind(original: trimesh.Trimesh, points: FloatArray, face: IntArray) -> FloatArray:
    """Name the edge (``convex_edge`` / ``reflex_edge``) nearest to each point."""
    v = np.asarray(original.vertices, dtype=np.float64)
    f = np.asarray(original.faces, dtype=np.int64)
    normals, _ = face_normals(v, f)
    adj = edge_adjacency(f)
    bend = bend_angles(normals, v, adj)
    bary = trimesh.triangles.points_to_barycentric(  # type: ignore[no-untyped-call]
        original.triangles[face], points
    )
    # Edge j joins corners j, j + 1: the corner (j + 2) % 3 has the smallest coordinate.
    j = (np.argmin(bary, axis=1) + 1) % 3
    edge = adj.face_edges[face, j]
    return np.where(bend[edge] < 0, "reflex_edge", "convex_edge").astype(object)


def mesh_checks(
    vertices: FloatArray, faces: IntArray, *, crossing_pairs: int | None = None
) -> dict[str, Any]:
    """Return closure, orientation, degenerate faces and crossings of a mesh as a file holds it.

    Vertices at exactly the same position are merged first, as a reader that welds
    coincident vertices does: a shell that is closed only because two copies of a point
    are kept apart does not count as closed.

    Parameters
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    crossing_pairs : int, optional
        The crossing triangle pairs of exactly these arrays when already counted by
        :func:`shellvox.offset.crossing.intersections.intersecting_pairs` (with other meshes beside
        them, whose pairs are not among these); used when no vertex is merged (merging changes which
        pairs share a vertex), else they are counted here.

    Returns
    -------
    dict
        ``n_faces``; ``coincident_vertices`` (vertices at the position of another);
        ``zero_area_faces`` (exactly zero area, after merging) and ``zero_length_edges``;
        after merging: ``closed``, ``oriented`` (consistent winding, positive volume),
        ``self_intersections``
        (:func:`shellvox.offset.crossing.intersections.count_self_intersections`) and ``volume_mm3``
        (``None`` unless closed); ``min_angle_deg``, the smallest angle of a triangle (degrees;
        ``None`` without faces).
    """
    if faces.shape[0] == 0:
        return {
            "n_faces": 0,
            "coincident_vertices": 0,
            "zero_area_faces": 0,
            "zero_length_edges": 0,
            "closed": True,
            "oriented": True,
            "self_intersections": 0,
            "volume_mm3": 0.0,
            "min_angle_deg": None,
        }
    unique, inverse = np.unique(vertices, axis=0, return_inverse=True)
    merged = np.asarray(inverse, dtype=np.int64).reshape(-1)[faces]
    tri = unique[merged]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    edges = np.unique(
        np.sort(np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2), axis=1),
        axis=0,
    )
    mesh = trimesh.Trimesh(unique, merged, process=False)
    closed = bool(mesh.is_watertight)
    volume = float(mesh.volume) if closed else None
    return {
        "n_faces": int(faces.shape[0]),
        "coincident_vertices": int(len(vertices) - len(unique)),
        "zero_area_faces": int(np.count_nonzero(area2 == 0.0)),
        "zero_length_edges": int(
            np.count_nonzero(np.all(vertices[edges[:, 0]] == vertices[edges[:, 1]], axis=1))
        ),
        "closed": closed,
        "oriented": bool(mesh.is_winding_consistent) and (volume is None or volume > 0),
        "self_intersections": count_self_intersections(unique, merged)
        if crossing_pairs is None or len(unique) != len(vertices)
        else int(crossing_pairs),
        "volume_mm3": volume,
        "min_angle_deg": float(smallest_angles(vertices[faces]).min()),
    }


def nested_in(
    inner: tuple[FloatArray, IntArray],
    outer: tuple[FloatArray, IntArray],
    *,
    crossing_free: bool = False,
) -> bool:
    """Return whether the closed mesh `inner` lies strictly inside the closed mesh `outer`.

    The two surfaces must not cross, and one vertex of every connected component of
    `inner` must be inside `outer` (generalised winding number above one half); without
    crossings, each component is then entirely inside.

    Parameters
    ----------
    inner, outer : (vertices (n, 3) float64 mm, faces (m, 3) int64)
    crossing_free : bool, optional
        The two, exactly as given, were already tested together with no crossing pair
        (:func:`shellvox.offset.crossing.intersections.intersecting_pairs`): only the winding test
        is left.

    Returns
    -------
    bool
    """
    if inner[1].shape[0] == 0:
        return True
    if outer[1].shape[0] == 0:
        return False
    _, label = scipy.sparse.csgraph.connected_components(
        scipy.sparse.coo_matrix(
            (np.ones(inner[1].size), (inner[1].reshape(-1), np.roll(inner[1], 1, 1).reshape(-1))),
            shape=(len(inner[0]), len(inner[0])),
        ),
        directed=False,
    )
    used = np.zeros(len(inner[0]), dtype=bool)
    used[inner[1].reshape(-1)] = True
    _, probe = np.unique(label[used], return_index=True)
    probe_pts = inner[0][np.flatnonzero(used)[probe]]
    if not np.all(winding_numbers(outer[0], outer[1], probe_pts) > 0.5):
        return False
    if crossing_free:
        return True
    both_v = np.concatenate([outer[0], inner[0]])
    both_f = np.concatenate([outer[1], inner[1] + len(outer[0])])
    # One test of both (one tolerance): a pair of one face of each must not cross (the
    # pairs among the outer faces alone are not tested).
    inner_faces = np.arange(len(both_f)) >= len(outer[1])
    pairs = intersecting_pairs(both_v, both_f, only=inner_faces)
    return not np.any((pairs[:, 0] < len(outer[1])) & (pairs[:, 1] >= len(outer[1])))
