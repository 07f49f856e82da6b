"""Face normals, triangle angles and edge-face adjacency of closed, oriented triangle meshes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shellvox.offset._validate import FloatArray, IntArray


@dataclass(frozen=True)
class EdgeAdjacency:
    """Each undirected edge of a closed mesh with its two faces.

    Attributes
    ----------
    edges : (E, 2) int64
        Vertex indices ``(a, b)``, ordered as the edge runs in ``faces[face_left]``.
    face_left : (E,) int64
        The face in which the edge runs ``a -> b``.
    face_right : (E,) int64
        The face in which the edge runs ``b -> a``.
    face_edges : (F, 3) int64
        Edge index of face corner pair ``(i, i + 1)``; edge ``j`` of face ``f`` joins
        ``faces[f, j]`` and ``faces[f, (j + 1) % 3]``.
    """

    edges: IntArray
    face_left: IntArray
    face_right: IntArray
    face_edges: IntArray


def face_normals(vertices: FloatArray, faces: IntArray) -> tuple[FloatArray, FloatArray]:
    """Return unit face normals and face areas.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64

    Returns
    -------
    normals : (F, 3) float64
        Unit outward normals; zero rows for degenerate faces.
    areas : (F,) float64, mm^2
    """
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    scale = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    valid = norm > 1e-14 * scale * scale
    normals = np.zeros_like(cross)
    normals[valid] = cross[valid] / norm[valid, None]
    return normals, 0.5 * norm


def smallest_angles(triangles: FloatArray) -> FloatArray:
    """Return the smallest angle of each triangle, (T,) float64 degrees.

    `triangles` is ``(T, 3, 3)`` float64 mm. ``atan2(|u x w|, u . w)`` at each corner keeps
    its precision near 0 and 180 degrees, where the arccosine of a dot product loses half
    the digits.
    """
    u = triangles[:, [1, 2, 0]] - triangles
    w = triangles[:, [2, 0, 1]] - triangles
    sine = np.linalg.norm(np.cross(u, w), axis=2)
    angles: FloatArray = np.degrees(np.arctan2(sine, np.einsum("tij,tij->ti", u, w)).min(axis=1))
    return angles


def edge_adjacency(faces: IntArray, *, open_ok: bool = False) -> EdgeAdjacency:
    """Pair every directed edge with its reverse.

    Parameters
    ----------
    faces : (F, 3) int64
        Closed, consistently oriented, edge-manifold triangles.
    open_ok : bool
        Pair only the edges that have one unique reverse, leaving out the others
        (holes' rims, non-manifold and misoriented edges; their ``face_edges`` are -1),
        instead of raising.

    Returns
    -------
    EdgeAdjacency

    Raises
    ------
    ValueError
        If some directed edge has no unique reverse (open, non-manifold or inconsistently
        oriented input).
    """
    n_faces = faces.shape[0]
    a = faces.reshape(-1)
    b = np.roll(faces, -1, axis=1).reshape(-1)
    n_vert = int(faces.max()) + 1
    key_fwd = a * n_vert + b
    key_rev = b * n_vert + a
    order = np.argsort(key_fwd, kind="stable")
    sorted_keys = key_fwd[order]
    repeated = sorted_keys[1:] == sorted_keys[:-1]
    if np.any(repeated) and not open_ok:
        raise ValueError(
            "faces must be edge-manifold and consistently oriented, got a repeated directed edge"
        )
    pos = np.searchsorted(sorted_keys, key_rev)
    pos = np.minimum(pos, len(sorted_keys) - 1)
    found = sorted_keys[pos] == key_rev
    if not np.all(found) and not open_ok:
        raise ValueError(
            f"faces must form a closed surface, got {int((~found).sum())} boundary edges"
        )
    partner = order[pos]
    half = np.arange(a.size)
    keep = a < b
    if open_ok:  # pair only halves whose key and whose reverse's key are unique
        unique = np.ones(a.size, dtype=bool)
        twice = np.flatnonzero(repeated)
        unique[order[twice]] = unique[order[twice + 1]] = False
        keep &= found & unique & unique[partner]
    edge_of_half = np.full(a.size, -1, dtype=np.int64)
    first = half[keep]
    edge_of_half[first] = np.arange(first.size)
    edge_of_half[partner[keep]] = np.arange(first.size)
    return EdgeAdjacency(
        edges=np.stack([a[keep], b[keep]], axis=1),
        face_left=first // 3,
        face_right=partner[keep] // 3,
        face_edges=edge_of_half.reshape(n_faces, 3),
    )


def bend_angles(normals: FloatArray, vertices: FloatArray, adj: EdgeAdjacency) -> FloatArray:
    """Return the signed bend angle of every edge: positive convex, negative reflex.

    Parameters
    ----------
    normals : (F, 3) float64
        Unit face normals.
    vertices : (V, 3) float64, mm
    adj : EdgeAdjacency

    Returns
    -------
    (E,) float64, radians in ``[-pi, pi]``
        Angle between the two face normals, signed by convexity.
    """
    n1 = normals[adj.face_left]
    n2 = normals[adj.face_right]
    t = vertices[adj.edges[:, 1]] - vertices[adj.edges[:, 0]]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    sin = np.einsum("ij,ij->i", np.cross(n1, n2), t)
    cos = np.einsum("ij,ij->i", n1, n2)
    return np.asarray(np.arctan2(sin, cos), dtype=np.float64)
