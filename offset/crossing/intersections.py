"""Count self-intersecting triangle pairs of a mesh (hierarchical hash grid, compiled test)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.crossing.crossing_kernels import cell_pair_hits, crossing_pairs
from shellvox.offset.crossing.exact_crossing import confirmed_crossings
from shellvox.offset.crossing.hash_grid import HashGrid, hash_grids

#: Default amplitude of a jitter (:mod:`shellvox.offset.reference.jitter`,
#: :mod:`shellvox.offset.field.simplify_passes`) as a fraction of the mesh extent: 0.5 nm
#: on a 50 mm part, 1e8 times the round-off of its coordinates, 1/2000 of the cleaning
#: tolerance (1 um at 0.5 mm) and 100 times the tolerance of the crossing test (1e-10 of
#: the extent), so that a crossing the jitter makes is larger than that tolerance and is
#: seen. At 1e-9, faces it left crossing below that tolerance were still flagged by
#: MeshLab on a torus.
JITTER_FRACTION = 1e-8
#: Threads testing candidate pairs at most (the compiled walk releases the GIL).
MAX_THREADS = 2


def intersecting_pairs(
    vertices: FloatArray,
    faces: IntArray,
    *,
    chunk: int = 200_000,
    only: npt.NDArray[np.bool_] | None = None,
) -> IntArray:
    """Return the pairs of triangles that cross each other.

    Pairs sharing an edge are skipped (they touch by construction), and coplanar
    overlaps, contacts of zero length and contacts along a common line where neither
    triangle straddles the other's plane are not counted: a pair counts when the segments
    in which each triangle meets the other's plane overlap over a positive length (the
    interval test of Moeller [1]_), with a tolerance of ``1e-10`` of the mesh extent;
    every pair that float test reports is confirmed in exact arithmetic
    (:func:`shellvox.offset.crossing.exact_crossing.confirmed_crossings`), so round-off near
    clustered vertices reports none that do not meet. Pairs sharing one vertex are tested too: both
    segments then start at that vertex, so they count when the triangles pass through each other
    beyond it (a fold at a vertex).

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    chunk : int, optional
        Candidate pairs walked by one call of the compiled narrow phase
        (:func:`shellvox.offset.crossing.crossing_kernels.cell_pair_hits`; they are never
        materialised).
    only : (F,) bool, optional
        Test only the pairs with at least one face in `only` (all pairs by default): the
        pairs of a mesh that changed in a few places, among faces changed or crossing
        before (the tolerance follows the extent of `vertices` as always).

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
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    tri = np.ascontiguousarray(vertices[faces], dtype=np.float64)
    scale = max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    eps = 1e-10 * scale
    lo = tri.min(axis=1) - eps
    hi = tri.max(axis=1) + eps
    active = np.ones(len(faces), dtype=np.bool_) if only is None else np.asarray(only, np.bool_)
    if not np.any(active):
        return np.zeros((0, 2), dtype=np.int64)
    hits: list[IntArray] = []
    with ThreadPoolExecutor(_threads(), thread_name_prefix="shellvox-crossings") as pool:
        for grid in hash_grids(lo, hi, None if only is None else active):
            # Leaders in sorted order, a bounded number of pairs at a time; the pairs are
            # walked and tested in one compiled loop (shellvox.offset.crossing.crossing_kernels),
            # which releases the GIL: the spans of a grid are tested side by side.
            def walk(span: tuple[int, int], grid: HashGrid = grid) -> IntArray:
                hit: IntArray = cell_pair_hits(
                    span[0],
                    span[1],
                    grid.later,
                    grid.skip,
                    grid.key,
                    grid.owner,
                    grid.low_cell,
                    grid.boxes,
                    lo,
                    hi,
                    grid.span,
                    faces,
                    tri,
                    eps,
                    active,
                )
                return hit

            hits.extend(pool.map(walk, grid.spans(chunk)))
    pairs = np.concatenate(hits) if hits else np.zeros((0, 2), dtype=np.int64)
    if len(pairs):  # the float test's round-off near clustered vertices, decided exactly
        pairs = pairs[confirmed_crossings(tri[pairs[:, 0]], tri[pairs[:, 1]])]
    code = np.sort(pairs[:, 0] * len(faces) + pairs[:, 1])
    return np.stack([code // len(faces), code % len(faces)], axis=1)


def _threads() -> int:
    """Return the narrow phase's threads: this process's CPUs, at most ``MAX_THREADS``."""
    return max(1, min(MAX_THREADS, len(os.sched_getaffinity(0))))


def _candidate_pairs(
    lo: FloatArray,
    hi: FloatArray,
    *,
    chunk: int = 200_000,
    active: npt.NDArray[np.bool_] | None = None,
) -> tuple[IntArray, IntArray]:
    """Return the pairs ``i < j`` of overlapping boxes (closed), sorted by ``(i, j)``.

    All of :func:`_candidate_chunks` at once, sorted.

    Parameters
    ----------
    lo, hi : (F, 3) float64, mm
        Box corners.
    chunk, active : optional
        See :func:`_candidate_chunks`.

    Returns
    -------
    first, second : (P,) int64
    """
    n_box = len(lo)
    codes = [a * n_box + b for a, b in _candidate_chunks(lo, hi, chunk=chunk, active=active)]
    pair = np.sort(np.concatenate(codes)) if codes else np.zeros(0, dtype=np.int64)
    return pair // max(n_box, 1), pair % max(n_box, 1)


def _candidate_chunks(
    lo: FloatArray,
    hi: FloatArray,
    *,
    chunk: int = 200_000,
    active: npt.NDArray[np.bool_] | None = None,
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the pairs ``i < j`` of overlapping boxes (closed), each exactly once.

    The pairs of every grid of :func:`shellvox.offset.crossing.hash_grid.hash_grids`, a bounded
    number at a time, so memory is ``O(F + chunk)`` however many boxes crowd into one cell (fans of
    sliver triangles put over a thousand there).

    Parameters
    ----------
    lo, hi : (F, 3) float64, mm
        Box corners.
    chunk : int, optional
        Candidate pairs generated at once, at least those of one box in one cell.
    active : (F,) bool, optional
        Only the pairs with an active box (all by default).

    Yields
    ------
    first, second : (p,) int64
        Overlapping pairs, ``first < second``, in no particular order.
    """
    for grid in hash_grids(lo, hi, active):
        for a0, a1 in grid.spans(chunk):
            cnt = grid.later[a0:a1]
            a = np.repeat(np.arange(a0, a1), cnt)
            b = a + 1 + np.repeat(grid.skip[a0:a1], cnt)
            b += np.arange(a.size) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            la, lb = grid.owner[a], grid.owner[b]
            here = grid.key[a]
            del a, b
            low = np.maximum(grid.low_cell[la], grid.low_cell[lb])  # floor is monotone
            fa, fb = grid.boxes[la], grid.boxes[lb]
            span = grid.span
            # Overlap, and this cell is the one of the intersection's low corner.
            keep = np.all((lo[fa] <= hi[fb]) & (lo[fb] <= hi[fa]), axis=1) & (
                (low[:, 0] * span[1] + low[:, 1]) * span[2] + low[:, 2] == here
            )
            fa, fb = fa[keep], fb[keep]
            yield np.minimum(fa, fb), np.maximum(fa, fb)


def coplanar_pairs(vertices: FloatArray, faces: IntArray, *, chunk: int = 200_000) -> IntArray:
    """Return the pairs of triangles that share no vertex and lie in one plane.

    These are the pairs :func:`intersecting_pairs` leaves undecided: bounding boxes
    overlapping, and the corners of one triangle within its tolerance (``1e-10`` of the
    mesh extent) of the other's plane. A test without such a tolerance reads their
    round-off as crossings at random (see :mod:`shellvox.offset.reference.jitter`).

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    chunk : int, optional
        Candidate pairs generated and tested at once (bounds memory).

    Returns
    -------
    (P, 2) int64
        Face index pairs ``i < j``, sorted.
    """
    if len(faces) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    tri = vertices[faces]
    eps = 1e-10 * max(float(np.ptp(vertices, axis=0).max()), 1e-12)
    hits = []
    for a, b in _candidate_chunks(tri.min(axis=1) - eps, tri.max(axis=1) + eps, chunk=chunk):
        apart = ~(faces[a][:, :, None] == faces[b][:, None, :]).any(axis=(1, 2))
        a, b = a[apart], b[apart]
        _, _, da, db = _plane_distances(tri[a], tri[b], eps)
        mask = np.all(db == 0, axis=1) | np.all(da == 0, axis=1)
        hits.append(a[mask] * len(faces) + b[mask])
    code = np.sort(np.concatenate(hits)) if hits else np.zeros(0, dtype=np.int64)
    return np.stack([code // len(faces), code % len(faces)], axis=1)


def _plane_distances(
    a: FloatArray, b: FloatArray, eps: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return the unit normals and the corners' distances to the other's plane.

    For ``(P, 3, 3)`` triangles `a` and `b`: normals ``na, nb`` ``(P, 3)``, and ``da``
    (`a`'s corners to plane `b`), ``db`` ``(P, 3)`` mm, those within `eps` set to 0.
    """
    na = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    nb = np.cross(b[:, 1] - b[:, 0], b[:, 2] - b[:, 0])
    na /= np.maximum(np.linalg.norm(na, axis=1, keepdims=True), 1e-300)
    nb /= np.maximum(np.linalg.norm(nb, axis=1, keepdims=True), 1e-300)
    db = np.einsum("pij,pj->pi", b - a[:, :1], na)  # b's corners vs plane a
    da = np.einsum("pij,pj->pi", a - b[:, :1], nb)
    db = np.where(np.abs(db) <= eps, 0.0, db)
    da = np.where(np.abs(da) <= eps, 0.0, da)
    return na, nb, da, db


def _crossing(a: FloatArray, b: FloatArray, eps: float) -> npt.NDArray[np.bool_]:
    """Triangle-triangle crossing test on ``(P, 3, 3)`` pairs; ``(P,)`` bool.

    The narrow phase of :func:`intersecting_pairs`
    (:func:`shellvox.offset.crossing.crossing_kernels.crossing_kernel`), pair by pair.
    """
    out = np.zeros(len(a), dtype=np.bool_)
    crossing_pairs(
        np.ascontiguousarray(a, dtype=np.float64),
        np.ascontiguousarray(b, dtype=np.float64),
        float(eps),
        out,
    )
    return out


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
