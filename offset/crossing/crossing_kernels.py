"""Compiled narrow phase of the crossing test (numba).

It serves :func:`shellvox.offset.crossing.intersections.intersecting_pairs`.

The triangle-triangle test runs once per candidate pair, tens of millions of times on a
shell of a million triangles; as numpy passes over ``(P, 3, 3)`` temporaries it took
three quarters of the check. Here the pairs of one hash-grid cell are walked and tested
in one compiled loop without materialising them (:func:`cell_pair_hits`), and the test
(:func:`crossing_kernel`) is the interval test of Moeller [1]_ exactly as documented in
:func:`shellvox.offset.crossing.intersections.intersecting_pairs`.

Nothing here checks its input.

References
----------
.. [1] T. Moeller, "A fast triangle-triangle intersection test", Journal of Graphics
   Tools 2(2), 1997.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from shellvox.voxel._compiled import kernel


def _jit(function: Callable[..., Any]) -> Callable[..., Any]:
    """Compile ``function`` with :func:`~shellvox.voxel._compiled.kernel` (the Python one stays)."""
    compiled: Callable[..., Any] = kernel(function)
    return compiled


def _interval_py(t, d0, d1, d2, l0, l1, l2):  # type: ignore[no-untyped-def]
    """Return the parameter interval along the line ``l`` where triangle ``t`` (3, 3) meets a plane.

    ``d0, d1, d2`` are its corners' distances to that plane (0 within the tolerance).
    Returns ``(inf, -inf)`` when it does not meet it.
    """
    p = (
        t[0, 0] * l0 + t[0, 1] * l1 + t[0, 2] * l2,
        t[1, 0] * l0 + t[1, 1] * l1 + t[1, 2] * l2,
        t[2, 0] * l0 + t[2, 1] * l1 + t[2, 2] * l2,
    )
    d = (d0, d1, d2)
    lo = np.inf
    hi = -np.inf
    for i in range(3):
        j = (i + 1) % 3
        if d[i] * d[j] < 0:
            s = p[i] + (p[j] - p[i]) * (d[i] / (d[i] - d[j]))
            lo = min(lo, s)
            hi = max(hi, s)
    for i in range(3):
        if d[i] == 0:
            lo = min(lo, p[i])
            hi = max(hi, p[i])
    return lo, hi


_interval = _jit(_interval_py)


def _unit_normal_py(t):  # type: ignore[no-untyped-def]
    """Return the unit normal ``(t1 - t0) x (t2 - t0)`` of ``t`` (3, 3); zero stays zero."""
    u0, u1, u2 = t[1, 0] - t[0, 0], t[1, 1] - t[0, 1], t[1, 2] - t[0, 2]
    v0, v1, v2 = t[2, 0] - t[0, 0], t[2, 1] - t[0, 1], t[2, 2] - t[0, 2]
    n0 = u1 * v2 - u2 * v1
    n1 = u2 * v0 - u0 * v2
    n2 = u0 * v1 - u1 * v0
    length = max(np.sqrt(n0 * n0 + n1 * n1 + n2 * n2), 1e-300)
    return n0 / length, n1 / length, n2 / length


_unit_normal = _jit(_unit_normal_py)


def _plane_offset_py(t, i, o, n0, n1, n2, eps):  # type: ignore[no-untyped-def]
    """Return the distance of corner ``t[i]`` to the plane through ``o`` (3,), normal ``n``.

    Signed; zero within ``eps``.
    """
    x = (t[i, 0] - o[0]) * n0 + (t[i, 1] - o[1]) * n1 + (t[i, 2] - o[2]) * n2
    return 0.0 if abs(x) <= eps else x


_plane_offset = _jit(_plane_offset_py)


def _crossing_kernel_py(a, b, eps):  # type: ignore[no-untyped-def]
    """Return whether triangles ``a`` and ``b`` (3, 3) float64 mm cross.

    They cross when neither lies strictly on one side of the other's plane, neither lies
    in it (corners within ``eps``), one straddles the other's plane, and the segments in
    which each meets the other's plane overlap by more than ``eps`` along the line of
    the two planes.
    """
    na0, na1, na2 = _unit_normal(a)
    nb0, nb1, nb2 = _unit_normal(b)
    db0 = _plane_offset(b, 0, a[0], na0, na1, na2, eps)  # b's corners vs plane a
    db1 = _plane_offset(b, 1, a[0], na0, na1, na2, eps)
    db2 = _plane_offset(b, 2, a[0], na0, na1, na2, eps)
    da0 = _plane_offset(a, 0, b[0], nb0, nb1, nb2, eps)  # a's corners vs plane b
    da1 = _plane_offset(a, 1, b[0], nb0, nb1, nb2, eps)
    da2 = _plane_offset(a, 2, b[0], nb0, nb1, nb2, eps)
    straddle_b = (db0 > 0 or db1 > 0 or db2 > 0) and (db0 < 0 or db1 < 0 or db2 < 0)
    straddle_a = (da0 > 0 or da1 > 0 or da2 > 0) and (da0 < 0 or da1 < 0 or da2 < 0)
    if not (straddle_a or straddle_b):
        return False
    if (
        (db0 > 0 and db1 > 0 and db2 > 0)
        or (db0 < 0 and db1 < 0 and db2 < 0)
        or (da0 > 0 and da1 > 0 and da2 > 0)
        or (da0 < 0 and da1 < 0 and da2 < 0)
    ):
        return False  # separated
    if (db0 == 0 and db1 == 0 and db2 == 0) or (da0 == 0 and da1 == 0 and da2 == 0):
        return False  # coplanar
    l0 = na1 * nb2 - na2 * nb1
    l1 = na2 * nb0 - na0 * nb2
    l2 = na0 * nb1 - na1 * nb0
    lo_a, hi_a = _interval(a, da0, da1, da2, l0, l1, l2)
    lo_b, hi_b = _interval(b, db0, db1, db2, l0, l1, l2)
    return min(hi_a, hi_b) - max(lo_a, lo_b) > eps


crossing_kernel = _jit(_crossing_kernel_py)


def _crossing_pairs_py(a, b, eps, out):  # type: ignore[no-untyped-def]
    """Write :func:`crossing_kernel` of every pair ``a[p], b[p]`` (P, 3, 3) into ``out``."""
    for p in range(a.shape[0]):
        out[p] = crossing_kernel(a[p], b[p], eps)


crossing_pairs = _jit(_crossing_pairs_py)


def _cell_pair_hits_py(  # type: ignore[no-untyped-def]
    a0, a1, later, skip, key_sorted, owner_sorted, i0, boxes, lo, hi, span, faces, tri, eps, active
):
    """Crossing pairs among the entries ``a0 .. a1 - 1`` of a sorted hash grid.

    Entry ``a`` pairs with the ``later[a]`` entries after its next ``skip[a]`` (same
    cell). A pair is tested only in the cell of the low corner of the boxes' intersection
    (so once), when the boxes overlap (closed), the triangles share fewer than two
    vertices and at least one of them is ``active``.

    Parameters
    ----------
    a0, a1 : int
    later, skip : (E,) int64
    key_sorted, owner_sorted : (E,) int64
        Cell key and binned box (index into ``boxes``) of each entry, sorted by cell.
    i0 : (B,) int64 (B, 3)
        Low cell of each binned box.
    boxes : (B,) int64
        Face index of each binned box.
    lo, hi : (F, 3) float64, mm
    span : (3,) int64
        Cells per axis (for the key).
    faces : (F, 3) int64
    tri : (F, 3, 3) float64, mm
    eps : float, mm
    active : (F,) bool

    Returns
    -------
    (H, 2) int64
        Face pairs ``i < j`` that cross, in no particular order.
    """
    cap = 64
    out = np.empty((cap, 2), dtype=np.int64)
    n = 0
    for a in range(a0, a1):
        la = owner_sorted[a]
        fa = boxes[la]
        here = key_sorted[a]
        first = a + 1 + skip[a]
        for b in range(first, first + later[a]):
            lb = owner_sorted[b]
            fb = boxes[lb]
            if not (active[fa] or active[fb]):
                continue
            if (
                lo[fa, 0] > hi[fb, 0]
                or lo[fb, 0] > hi[fa, 0]
                or lo[fa, 1] > hi[fb, 1]
                or lo[fb, 1] > hi[fa, 1]
                or lo[fa, 2] > hi[fb, 2]
                or lo[fb, 2] > hi[fa, 2]
            ):
                continue
            low0 = max(i0[la, 0], i0[lb, 0])
            low1 = max(i0[la, 1], i0[lb, 1])
            low2 = max(i0[la, 2], i0[lb, 2])
            if (low0 * span[1] + low1) * span[2] + low2 != here:
                continue
            shared = 0
            for i in range(3):
                for j in range(3):
                    if faces[fa, i] == faces[fb, j]:
                        shared += 1
            if shared >= 2:
                continue
            if crossing_kernel(tri[fa], tri[fb], eps):
                if n == cap:
                    grown = np.empty((2 * cap, 2), dtype=np.int64)
                    grown[:n] = out[:n]
                    out = grown
                    cap *= 2
                out[n, 0] = min(fa, fb)
                out[n, 1] = max(fa, fb)
                n += 1
    return out[:n]


cell_pair_hits = _jit(_cell_pair_hits_py)
