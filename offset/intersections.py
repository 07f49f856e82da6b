"""Count self-intersecting triangle pairs of a mesh (broad phase R-tree, vectorised test)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from offset._validate import FloatArray, IntArray


def intersecting_pairs(vertices: FloatArray, faces: IntArray, *, chunk: int = 200_000) -> IntArray:
    """Return the pairs of triangles that cross each other.

    Pairs sharing a vertex index are skipped (edge neighbours touch by construction), and
    coplanar overlaps, contacts of zero length and contacts along a common line where
    neither triangle straddles the other's plane are not counted: a pair counts when the
    segments in which each triangle meets the other's plane overlap over a positive length
    (the interval test of Moeller [1]_), with a tolerance of ``1e-10`` of the mesh extent.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    chunk : int, optional
        Candidate pairs tested at once (bounds memory).

    Returns
    -------
    (P, 2) int64
        Face index pairs ``i < j``.

    References
    ----------
    .. [1] T. Moeller, "A fast triangle-triangle intersection test", Journal of Graphics
       Tools 2(2), 1997.
    """
    if len(faces) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    tri = vertices[faces]
    scale = max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    eps = 1e-10 * scale
    lo = tri.min(axis=1) - eps
    hi = tri.max(axis=1) + eps
    first, second = _candidate_pairs(lo, hi)
    shared = (faces[first][:, :, None] == faces[second][:, None, :]).any(axis=(1, 2))
    first, second = first[~shared], second[~shared]
    hits = [
        _crossing(tri[first[s : s + chunk]], tri[second[s : s + chunk]], eps)
        for s in range(0, len(first), chunk)
    ]
    mask = np.concatenate(hits) if hits else np.zeros(0, dtype=bool)
    return np.stack([first[mask], second[mask]], axis=1)


def _candidate_pairs(lo: FloatArray, hi: FloatArray) -> tuple[IntArray, IntArray]:
    """Return box pairs ``i < j`` sharing a cell of a uniform hash grid (a superset of overlaps).

    Parameters
    ----------
    lo, hi : (F, 3) float64, mm
        Box corners.

    Returns
    -------
    first, second : (P,) int64
    """
    size = float(np.median((hi - lo).max(axis=1))) * 2.0 + 1e-12
    i0 = np.floor(lo / size).astype(np.int64)
    n = np.floor(hi / size).astype(np.int64) - i0 + 1
    per = n.prod(axis=1)
    owner = np.repeat(np.arange(len(lo)), per)
    rank = np.arange(owner.size) - np.repeat(np.cumsum(per) - per, per)
    nx, ny = n[owner, 0], n[owner, 1]
    cell = i0[owner] + np.stack([rank % nx, (rank // nx) % ny, rank // (nx * ny)], axis=1)
    cell -= cell.min(axis=0)
    span = cell.max(axis=0) + 1
    key = (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]  # one int64 per cell
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    start = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    size_g = np.diff(np.r_[start, key_sorted.size])
    pos_rank: IntArray = np.arange(key_sorted.size) - np.repeat(start, size_g)
    later = np.repeat(size_g, size_g) - pos_rank - 1
    a = np.repeat(np.arange(key_sorted.size), later)
    b = a + 1 + (np.arange(a.size) - np.repeat(np.cumsum(later) - later, later))
    fa, fb = owner[order[a]], owner[order[b]]
    fa, fb = np.minimum(fa, fb), np.maximum(fa, fb)
    pair = np.unique(fa * len(lo) + fb)
    pair = pair[pair // len(lo) != pair % len(lo)]
    first, second = pair // len(lo), pair % len(lo)
    overlap = np.all((lo[first] <= hi[second]) & (lo[second] <= hi[first]), axis=1)
    return first[overlap], second[overlap]


def _crossing(a: FloatArray, b: FloatArray, eps: float) -> npt.NDArray[np.bool_]:
    """Vectorised triangle-triangle crossing test on ``(P, 3, 3)`` pairs; ``(P,)`` bool."""
    na = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    nb = np.cross(b[:, 1] - b[:, 0], b[:, 2] - b[:, 0])
    na /= np.maximum(np.linalg.norm(na, axis=1, keepdims=True), 1e-300)
    nb /= np.maximum(np.linalg.norm(nb, axis=1, keepdims=True), 1e-300)
    db = np.einsum("pij,pj->pi", b - a[:, :1], na)  # b's corners vs plane a
    da = np.einsum("pij,pj->pi", a - b[:, :1], nb)
    db = np.where(np.abs(db) <= eps, 0.0, db)
    da = np.where(np.abs(da) <= eps, 0.0, da)
    separated = (
        np.all(db > 0, axis=1) | np.all(db < 0, axis=1) | np.all(da > 0, axis=1)
        | np.all(da < 0, axis=1)
    )
    coplanar = np.all(db == 0, axis=1) | np.all(da == 0, axis=1)
    line = np.cross(na, nb)
    lo_a, hi_a = _interval(a, da, line)
    lo_b, hi_b = _interval(b, db, line)
    overlap = np.minimum(hi_a, hi_b) - np.maximum(lo_a, lo_b)
    straddle = (np.any(db > 0, axis=1) & np.any(db < 0, axis=1)) | (
        np.any(da > 0, axis=1) & np.any(da < 0, axis=1)
    )
    return np.asarray(~separated & ~coplanar & straddle & (overlap > eps), dtype=bool)


def _interval(t: FloatArray, d: FloatArray, line: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return the parameter interval along ``line`` where triangles meet the other plane."""
    p = np.einsum("pij,pj->pi", t, line)
    i = np.array([0, 1, 2])
    j = np.array([1, 2, 0])
    di, dj = d[:, i], d[:, j]
    cross = di * dj < 0
    denom = np.where(cross, di - dj, 1.0)
    s = p[:, i] + (p[:, j] - p[:, i]) * np.where(cross, di / denom, 0.0)
    on = d == 0
    cand = np.concatenate([np.where(cross, s, np.nan), np.where(on, p, np.nan)], axis=1)
    valid = ~np.isnan(cand)
    lo = np.where(valid, cand, np.inf).min(axis=1)
    hi = np.where(valid, cand, -np.inf).max(axis=1)
    return lo, hi


def count_self_intersections(vertices: FloatArray, faces: IntArray) -> int:
    """Return the number of crossing triangle pairs, see :func:`intersecting_pairs`.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64

    Returns
    -------
    int
    """
    return int(intersecting_pairs(vertices, faces).shape[0])
