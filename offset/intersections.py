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
        Candidate pairs generated and tested at once (bounds memory).

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
    first, second = _candidate_pairs(lo, hi, chunk=chunk)
    hits = []
    for s in range(0, len(first), chunk):
        a, b = first[s : s + chunk], second[s : s + chunk]
        shared = (faces[a][:, :, None] == faces[b][:, None, :]).any(axis=(1, 2))
        a, b = a[~shared], b[~shared]
        mask = _crossing(tri[a], tri[b], eps)
        hits.append(np.stack([a[mask], b[mask]], axis=1))
    return np.concatenate(hits) if hits else np.zeros((0, 2), dtype=np.int64)


def _candidate_pairs(
    lo: FloatArray, hi: FloatArray, *, chunk: int = 200_000
) -> tuple[IntArray, IntArray]:
    """Return the pairs ``i < j`` of overlapping boxes (closed), sorted by ``(i, j)``.

    Boxes are binned into the cells of a uniform hash grid they touch; pairs sharing a
    cell are candidates. A pair is kept only in the cell holding the low corner of the
    two boxes' intersection (``max(lo_i, lo_j)``), where both boxes are binned, so each
    overlapping pair is found exactly once and the pairs of a cell can be generated and
    tested a bounded number at a time: memory is ``O(F + chunk)`` however many boxes
    crowd into one cell (a shell's fans of sliver triangles put over a thousand there).

    Parameters
    ----------
    lo, hi : (F, 3) float64, mm
        Box corners.
    chunk : int, optional
        Candidate pairs generated at once, at least those of one box in one cell.

    Returns
    -------
    first, second : (P,) int64
    """
    n_box = len(lo)
    # Cells of the median box size: on offset shells (fans of slivers) half as many
    # candidates, and twice as fast, as cells twice that size; the result is the same.
    size = float(np.median((hi - lo).max(axis=1))) + 1e-12
    i0 = np.floor(lo / size).astype(np.int64)
    n = np.floor(hi / size).astype(np.int64) - i0 + 1
    per = n.prod(axis=1)
    owner = np.repeat(np.arange(n_box), per)
    rank = np.arange(owner.size) - np.repeat(np.cumsum(per) - per, per)
    nx, ny = n[owner, 0], n[owner, 1]
    cell = i0[owner] + np.stack([rank % nx, (rank // nx) % ny, rank // (nx * ny)], axis=1)
    del rank, nx, ny
    cell_lo = cell.min(axis=0)
    cell -= cell_lo
    span = cell.max(axis=0) + 1
    key = (cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2]  # one int64 per cell
    del cell
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    owner_sorted = owner[order]
    del key, owner, order
    start = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    size_g = np.diff(np.r_[start, key_sorted.size])
    # Entry `a` of the sorted list pairs with the `later[a]` entries after it in its cell.
    later = np.repeat(size_g, size_g) - (np.arange(key_sorted.size) - np.repeat(start, size_g)) - 1
    del start, size_g
    ends = np.cumsum(later)
    pairs = []
    a0 = 0
    while a0 < key_sorted.size:
        # Entries a0 .. a1 - 1 give at most `chunk` pairs (at least one entry's worth).
        base = int(ends[a0 - 1]) if a0 else 0
        a1 = max(int(np.searchsorted(ends, base + chunk, side="right")), a0 + 1)
        cnt = later[a0:a1]
        a = np.repeat(np.arange(a0, a1), cnt)
        b = a + 1 + (np.arange(a.size) - np.repeat(np.cumsum(cnt) - cnt, cnt))
        fa, fb = owner_sorted[a], owner_sorted[b]
        fa, fb = np.minimum(fa, fb), np.maximum(fa, fb)
        here = key_sorted[a]
        del a, b
        # Overlap, and this cell is the one of the intersection's low corner.
        low = np.maximum(i0[fa], i0[fb]) - cell_lo  # floor is monotone: exact cell
        keep = (
            np.all((lo[fa] <= hi[fb]) & (lo[fb] <= hi[fa]), axis=1)
            & ((low[:, 0] * span[1] + low[:, 1]) * span[2] + low[:, 2] == here)
            & (fa != fb)
        )
        pairs.append(fa[keep] * n_box + fb[keep])
        a0 = a1
    pair = np.sort(np.concatenate(pairs)) if pairs else np.zeros(0, dtype=np.int64)
    return pair // n_box, pair % n_box


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
