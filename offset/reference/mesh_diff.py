"""Which faces of a mesh are unchanged from an earlier version of it (exact coordinates).

A robust shell is repaired in a few places (:func:`shellvox.offset.reference.core_cut.patch_core`,
or simplified where a few sub-micrometre triangles cross); the faces outside those places come out
of manifold3d with the same coordinates. A pair of such faces was already tested for crossing, so
only pairs involving a new face (or one that crossed before) need testing again.
"""

from __future__ import annotations

import numpy as np

from shellvox.offset._validate import FloatArray, IntArray


def face_origin(
    old_vertices: FloatArray, old_faces: IntArray, new_vertices: FloatArray, new_faces: IntArray
) -> IntArray:
    """Return, for every new face, the old face with the same corners, or -1.

    Faces are the same when their corners have bitwise equal coordinates in the same
    cyclic order (orientation kept; the first corner may differ).

    Parameters
    ----------
    old_vertices : (V, 3) float64, mm
    old_faces : (F, 3) int64
    new_vertices : (V', 3) float64, mm
    new_faces : (F', 3) int64

    Returns
    -------
    (F',) int64
        Index into `old_faces`, -1 for a face that is new.

    Examples
    --------
    >>> v = np.eye(3)
    >>> face_origin(v, np.array([[0, 1, 2]]), v[::-1], np.array([[1, 0, 2], [0, 1, 2]]))
    array([ 0, -1])
    """
    if len(new_faces) == 0 or len(old_faces) == 0:
        return np.full(len(new_faces), -1, dtype=np.int64)
    points = np.ascontiguousarray(np.concatenate([old_vertices, new_vertices]), np.float64)
    point_id = _row_ids(points.view(np.int64))  # bitwise equality of the coordinates
    old = _canonical(point_id[: len(old_vertices)][old_faces])
    new = _canonical(point_id[len(old_vertices) :][new_faces])
    face_id = _row_ids(np.concatenate([old, new]))
    old_id, new_id = face_id[: len(old)], face_id[len(old) :]
    owner = np.full(int(face_id.max()) + 1, -1, dtype=np.int64)
    owner[old_id] = np.arange(len(old))
    return np.asarray(owner[new_id], dtype=np.int64)


def _canonical(corners: IntArray) -> IntArray:
    """Rotate every row of ``(F, 3)`` point ids to start at its smallest id."""
    first = np.argmin(corners, axis=1)[:, None]
    return np.take_along_axis(corners, (first + np.arange(3)) % 3, axis=1)


def _row_ids(rows: IntArray) -> IntArray:
    """Return ids of the rows of ``(N, 3)`` int64: equal rows that sort together share one.

    Rows are sorted by a 64-bit hash and compared whole with their neighbour, so distinct
    rows never share an id; equal rows get one id unless a hash collision falls between
    them (then they look distinct, which only means more faces are tested again).
    """
    mixed = rows.astype(np.uint64) * np.array(_MIX, dtype=np.uint64)
    key = mixed[:, 0] ^ (mixed[:, 1] >> np.uint64(1)) ^ (mixed[:, 2] >> np.uint64(2))
    order = np.argsort(key)
    ordered = rows[order]
    step = np.any(ordered[1:] != ordered[:-1], axis=1)
    ids = np.empty(len(rows), dtype=np.int64)
    ids[order] = np.concatenate([[0], np.cumsum(step)])
    return ids


#: Odd 64-bit multipliers of the row hash (from splitmix64 and xxHash).
_MIX = (0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, 0xC2B2AE3D27D4EB4F)
