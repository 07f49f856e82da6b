"""One prism per flat patch: coplanar neighbouring faces of equal depth swept together.

Where several edge-connected faces lie in one plane and take the same depth, the union of
their prisms (:func:`shellvox.offset.reference.pieces.prisms`) is the prism over the patch they
form, and that is what is built here: the patch's own triangles moved to ``-D n`` (bottom) and
``+OUTSIDE_FRACTION D n`` (top), joined by walls along the patch boundary. One piece instead of one
per face matters far beyond the count: neighbouring face prisms overlap in coplanar caps and walls
(they are grown to overlap, see :mod:`shellvox.offset.reference.pieces`), which the Booleans cut
into many sliver triangles; a CAD-like mesh is mostly such patches.

As with the face prisms, the boundary moves out in the patch's plane by
``GROW_FRACTION * D`` (mitred corners, at most ten times that at sharp ones), so that no
surface edge lies on a piece's wall. A patch whose grown outline would fold (a triangle
turning over, the outline touching itself at a vertex, or two parts of the outline
closer than the growth) is left to the per-face prisms.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.pieces import GROW_FRACTION, OUTSIDE_FRACTION, Group

#: Faces whose unit normals differ by less than this (about radians) count as coplanar.
COPLANAR_TOL = 1e-9
#: Largest corner move, in units of the edge growth (see
#: :func:`shellvox.offset.reference.pieces.prisms`).
MAX_MITRE = 10.0


def flat_patches(pairs: IntArray, n_faces: int, d: FloatArray) -> tuple[IntArray, int]:
    """Return the patches of coplanar neighbouring faces that share a depth.

    Parameters
    ----------
    pairs : (C, 2) int64
        Edge-adjacent face pairs with the same plane (see :func:`coplanar_pairs`).
    n_faces : int
    d : (F,) float64, mm
        Depth per face.

    Returns
    -------
    label : (F,) int64
        Patch of each face, ``-1`` for faces alone in their patch.
    n_patches : int
        Number of patches (labels ``0 .. n_patches - 1``).
    """
    same = pairs[d[pairs[:, 0]] == d[pairs[:, 1]]]
    graph = scipy.sparse.coo_matrix(
        (np.ones(len(same)), (same[:, 0], same[:, 1])), shape=(n_faces, n_faces)
    )
    _, comp = scipy.sparse.csgraph.connected_components(graph, directed=False)
    size = np.bincount(comp)
    multi = size[comp] > 1
    label = np.full(n_faces, -1, dtype=np.int64)
    _, label[multi] = np.unique(comp[multi], return_inverse=True)
    return label, int(label.max()) + 1


def coplanar_pairs(normals: FloatArray, face_left: IntArray, face_right: IntArray) -> IntArray:
    """Return the edge-adjacent face pairs ``(C, 2) int64`` whose normals agree.

    Parameters
    ----------
    normals : (F, 3) float64
        Unit normals, zero rows for degenerate faces (never coplanar).
    face_left, face_right : (E,) int64
        The two faces of every edge.
    """
    n1, n2 = normals[face_left], normals[face_right]
    close = np.linalg.norm(n1 - n2, axis=1) <= COPLANAR_TOL
    close &= np.any(n1 != 0, axis=1) & np.any(n2 != 0, axis=1)
    return np.stack([face_left[close], face_right[close]], axis=1)


def patch_prisms(
    vertices: FloatArray,
    faces: IntArray,
    normals: FloatArray,
    areas: FloatArray,
    label: IntArray,
    n_patches: int,
    d: FloatArray,
) -> tuple[list[Group], npt.NDArray[np.bool_]]:
    """Return one prism per patch, and which faces it covers.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    normals : (F, 3) float64
    areas : (F,) float64, mm^2
    label : (F,) int64
        Patch per face (:func:`flat_patches`), ``-1`` for none.
    n_patches : int
    d : (F,) float64, mm

    Returns
    -------
    groups : list of (points (1, P, 3) float64 mm, tris (T, 3) int64)
        One outward closed prism per patch that could be built.
    covered : (F,) bool
        Faces swept by those prisms; the others need their own prism.
    """
    covered = np.zeros(len(faces), dtype=bool)
    groups: list[Group] = []
    if n_patches == 0:
        return groups, covered
    order = np.argsort(label, kind="stable")
    start = np.searchsorted(label[order], np.arange(n_patches + 1))
    for k in range(n_patches):  # one iteration per patch, vectorised within
        members = order[start[k] : start[k + 1]]
        w = areas[members]
        n = (normals[members] * w[:, None]).sum(axis=0)
        n /= np.linalg.norm(n)
        piece = _prism(vertices, faces[members], n, float(d[members[0]]))
        if piece is not None:
            groups.append(piece)
            covered[members] = True
    return groups, covered


def _prism(vertices: FloatArray, tri: IntArray, n: FloatArray, depth: float) -> Group | None:
    """Return the grown prism over one patch, or None where the outline would fold.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    tri : (m, 3) int64
        The patch's faces (global vertex numbers), wound counter-clockwise about `n`.
    n : (3,) float64
        Unit outward normal of the plane.
    depth : float, mm
    """
    used, local = np.unique(tri, return_inverse=True)
    local = local.reshape(-1, 3)
    k = len(used)
    p = vertices[used]
    half = np.stack([local, np.roll(local, -1, axis=1)], axis=2).reshape(-1, 2)
    key = half[:, 0] * k + half[:, 1]
    bnd = half[~np.isin(key, half[:, 1] * k + half[:, 0])]
    if len(np.unique(bnd[:, 0])) != len(bnd):
        return None  # the outline touches itself at a vertex
    nxt = np.full(k, -1)
    prv = np.full(k, -1)
    nxt[bnd[:, 0]] = bnd[:, 1]
    prv[bnd[:, 1]] = bnd[:, 0]
    b = bnd[:, 0]
    e_out = np.cross(p[nxt[b]] - p[b], n)
    e_in = np.cross(p[b] - p[prv[b]], n)
    e_out /= np.linalg.norm(e_out, axis=1, keepdims=True)
    e_in /= np.linalg.norm(e_in, axis=1, keepdims=True)
    # Mitre: both boundary edges at a corner move out by g (bounded at sharp corners).
    g = GROW_FRACTION * depth
    cos = np.einsum("ij,ij->i", e_in, e_out)
    move = g * (e_in + e_out) / np.maximum(1.0 + cos, 2.0 / MAX_MITRE**2)[:, None]
    length = np.linalg.norm(move, axis=1, keepdims=True)
    move *= np.minimum(1.0, MAX_MITRE * g / np.maximum(length, 1e-300))
    q = p.copy()
    q[b] += move
    # No triangle may turn over (a thin triangle along the outline).
    turned = np.einsum(
        "ij,j->i", np.cross(q[local[:, 1]] - q[local[:, 0]], q[local[:, 2]] - q[local[:, 0]]), n
    )
    if np.any(turned <= 0):
        return None
    bottom = q - depth * n
    top = q + OUTSIDE_FRACTION * depth * n
    a0, a1 = bnd[:, 0], bnd[:, 1]
    walls = np.concatenate(
        [
            np.stack([a0, a1, k + a1], axis=1),
            np.stack([a0, k + a1, k + a0], axis=1),
        ]
    )
    tris = np.concatenate([local[:, ::-1], k + local, walls]).astype(np.int64)
    pts = np.concatenate([bottom, top])
    if len(intersecting_pairs(pts, tris)):
        return None  # two parts of the outline closer than the growth
    return pts[None], tris
