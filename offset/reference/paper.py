"""The paper's per-face offset: each corner from three moved planes (reference method).

Zhu and Chen [1]_ move every face plane inward by its own depth and take each corner of
the offset triangle as the intersection of the face's moved plane with the moved planes of
its two edge neighbours at that corner (the triangular pyramid construction, their
eqs. 1-6, is the closed form of this three-plane intersection). Faces keep their own
corners, so a vertex of valence above three gets several positions (the paper's "excess
extension surfaces"). Where the three planes are (nearly) dependent, e.g. coplanar
neighbours, the corner is moved along the face normal instead.

References
----------
.. [1] H. Zhu and K. Chen, "Boundary adjustment algorithm based on element
   triangulation", 2025.
"""

from __future__ import annotations

import numpy as np

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import edge_adjacency, face_normals

#: Three-plane systems with ``|det|`` below this (unit normals) count as singular.
SINGULAR_DET = 1e-6


def paper_offset(
    vertices: FloatArray, faces: IntArray, depth: FloatArray
) -> list[tuple[FloatArray, IntArray]]:
    """Return the paper's offset triangle soup per layer, merged where corners coincide.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    depth : (K, F) float64, mm
        Cumulative depth per layer and face.

    Returns
    -------
    list of (vertices (n, 3) float64 mm, faces (F, 3) int64)
        Face ``f`` of each layer is the offset of input face ``f``.
    """
    normals, _ = face_normals(vertices, faces)
    adj = edge_adjacency(faces)
    fidx = np.arange(len(faces))[:, None]
    other = np.where(
        adj.face_left[adj.face_edges] == fidx,
        adj.face_right[adj.face_edges],
        adj.face_left[adj.face_edges],
    )  # (F, 3): neighbour across edge j = (corner j, corner j + 1)
    prev_edge = np.roll(other, 1, axis=1)  # neighbour across edge (corner i - 1, corner i)
    a = np.stack(
        [
            np.broadcast_to(normals[:, None, :], (len(faces), 3, 3)),
            normals[prev_edge],
            normals[other],
        ],
        axis=2,
    )  # (F, 3 corners, 3 planes, 3)
    det = np.linalg.det(a)
    singular = np.abs(det) < SINGULAR_DET
    a_safe = np.where(singular[..., None, None], np.eye(3), a)
    corners = vertices[faces]
    out: list[tuple[FloatArray, IntArray]] = []
    for d in depth:
        offset_c = np.einsum("fj,fj->f", normals, corners[:, 0]) - d
        rhs = np.stack(
            [
                np.broadcast_to(offset_c[:, None], (len(faces), 3)),
                _plane_constant(normals, corners, d)[prev_edge],
                _plane_constant(normals, corners, d)[other],
            ],
            axis=2,
        )
        x = np.linalg.solve(a_safe, rhs[..., None])[..., 0]
        fallback = corners - d[:, None, None] * normals[:, None, :]
        x = np.where(singular[..., None], fallback, x)
        out.append(_merge_soup(x))
    return out


def _plane_constant(normals: FloatArray, corners: FloatArray, d: FloatArray) -> FloatArray:
    """Return ``c_f`` of the moved planes ``n_f . x = c_f``, shape ``(F,)``."""
    return np.asarray(np.einsum("fj,fj->f", normals, corners[:, 0]) - d, dtype=np.float64)


def _merge_soup(corners: FloatArray) -> tuple[FloatArray, IntArray]:
    """Merge corners equal to 1e-9 of the extent; ``(F, 3, 3)`` soup to indexed mesh."""
    pts = corners.reshape(-1, 3)
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-12)
    key = np.round(pts / (1e-9 * scale)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return np.ascontiguousarray(pts[first]), inverse.reshape(-1, 3).astype(np.int64)
