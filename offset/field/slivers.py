"""Slivers of a closed shell removed: needles collapsed, caps flipped, each move bounded.

Marching a sampled field makes triangles with an angle near zero where the surface passes
near a node, and Manifold's edge collapse keeps most of them: on the bunny's outer shell at
50 mm, 6,598 of 338,782 triangles have an angle under 1 degree, 42 under 0.01 degree. A
reader with float tolerances (MeshLab's self-intersection filter, a slicer) misjudges such
triangles, and they carry no shape. Three local moves remove them, worst sliver first:

* a *needle* loses its shortest edge: one end moves onto the other (an edge collapse), the
  end whose move shifts the surface less (a vertex on a crease stays, the other comes to
  it); no vertex leaves the surface it was on;
* a *cap* (an angle over 90 degrees) has the edge opposite that angle flipped with the
  neighbour across it, when the two triangulations of their quad part by little enough
  (the distance between the quad's two diagonals);
* otherwise the cap's wide corner first moves onto that edge (its foot point, as far as the
  cap is high), and the flip follows: the two new triangles lie in the neighbour's plane.

A move is made only when it keeps the shell a closed, oriented 2-manifold (the collapse's
link condition; a flip's new edge not already there), turns no triangle by more than
``MAX_TURN_DEG``, shifts the surface by at most `max_move_mm` (the collapsing vertex's
distance from the planes of the triangles it changes; the diagonals' distance; the cap's
height), and raises the smallest angle of the triangles it changes or removes. Moves of one
round touch disjoint stars; a sliver is tried again only when a move changed something
within two rings of it, for at most ``ROUNDS`` rounds. Locked triangles are changed only
by a first phase that collapses needles' edges shorter than a given length (sub-micrometre
vertex clusters), when asked.
The moves are compiled (:func:`shellvox.voxel._compiled.kernel`); a round's bookkeeping
(which triangles meet at each vertex) is numpy.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import smallest_angles
from shellvox.voxel._compiled import kernel

#: Triangles with an angle under this (degrees) are slivers.
MIN_ANGLE_DEG = 1.0

#: Largest turn (degrees) of a triangle's normal that a move may make.
MAX_TURN_DEG = 30.0

#: Rounds of moves at most.
ROUNDS = 12


class Desliver(NamedTuple):
    """A shell with its slivers removed where a move could, and what was done.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (T, 3) int64
        Unreferenced vertices removed.
    locked : (T,) bool or None
        The locked triangles among `faces` (None when none were given).
    changed : (T,) bool
        The triangles a move made or changed (the others are triangles of the input, as
        they were).
    collapsed, flipped : int
        Edges collapsed and flipped.
    left : int
        Triangles still with an angle under the threshold.
    """

    vertices: FloatArray
    faces: IntArray
    locked: npt.NDArray[np.bool_] | None
    changed: npt.NDArray[np.bool_]
    collapsed: int
    flipped: int
    left: int


def remove_slivers(
    vertices: FloatArray,
    faces: IntArray,
    max_move_mm: float,
    *,
    locked: npt.NDArray[np.bool_] | None = None,
    min_angle_deg: float = MIN_ANGLE_DEG,
    locked_collapse_mm: float = 0.0,
    fixed: npt.NDArray[np.bool_] | None = None,
) -> Desliver:
    """Collapse the needles and flip the caps of a closed, oriented 2-manifold shell.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (T, 3) int64
    max_move_mm : float, mm
        Largest distance a move may move the surface.
    locked : (T,) bool, optional
        Triangles that must stay as they are.
    min_angle_deg : float, optional
        Triangles with a smaller angle are slivers.
    locked_collapse_mm : float, optional, mm
        Before the other moves, needles with an edge at most this long, locked triangles
        too, lose that edge where the collapse moves the surface by at most this (no
        flips): the vertex clusters a marched surface makes where it passes a grid node,
        which a reader with an absolute tolerance (MeshLab's 1e-6) misjudges. 0 (default):
        locked triangles are never changed.
    fixed : (T,) bool, optional
        Triangles that must stay as they are, in both phases.

    Returns
    -------
    Desliver

    Examples
    --------
    A square of two triangles with a needle beside a vertex 1e-4 mm from a corner, closed
    by a pyramid under it, loses the needle:

    >>> v = np.array(
    ...     [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1e-4, 0, 0], [0.5, 0.5, -1]], dtype=float
    ... )
    >>> f = np.array(
    ...     [[0, 4, 2], [4, 1, 2], [0, 2, 3], [4, 0, 5], [1, 4, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]]
    ... )
    >>> out = remove_slivers(v, f, 1e-3)
    >>> out.collapsed, len(out.faces), out.left
    (1, 6, 0)
    """
    v = np.array(vertices, dtype=np.float64)  # a copy: a cap's corner moves
    f = np.array(faces, dtype=np.int64)
    lock = np.zeros(len(f), dtype=bool) if locked is None else np.array(locked, dtype=bool)
    hold = np.zeros(len(f), dtype=bool) if fixed is None else np.array(fixed, dtype=bool)
    collapsed = flipped = 0
    cos_turn = float(np.cos(np.radians(MAX_TURN_DEG)))
    worst = smallest_angles(v[f])
    made = np.zeros(len(f), dtype=bool)
    phases = [(max_move_mm, True)]  # (largest move, locked triangles kept and flips made)
    if locked_collapse_mm > 0 and lock.any():
        phases.insert(0, (min(locked_collapse_mm, max_move_mm), False))
    for move_mm, keep_locked in phases:
        retry = np.ones(len(f), dtype=bool)  # slivers whose neighbourhood changed since tried
        for _ in range(ROUNDS):
            kept = hold | (lock & keep_locked)  # triangles no move may change
            slivers = np.flatnonzero((worst < min_angle_deg) & ~kept & retry)
            if not keep_locked:  # needles with an edge that short only
                corners = v[f[slivers]]
                edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
                slivers = slivers[edges.min(axis=1) <= move_mm]
            if len(slivers) == 0:
                break
            corner = f.reshape(-1)
            order = np.argsort(corner, kind="stable") // 3  # the faces around each vertex
            start = np.concatenate([[0], np.cumsum(np.bincount(corner, minlength=len(v)))])
            touched = kept.copy()  # a kept triangle counts as touched: never changed
            changed = np.zeros(len(f), dtype=bool)
            dead = np.zeros(len(f), dtype=bool)
            worst_first = slivers[np.argsort(worst[slivers], kind="stable")]
            done = _round(
                v,
                f,
                worst,
                touched,
                changed,
                dead,
                order,
                start,
                worst_first,
                move_mm,
                cos_turn,
                keep_locked,
            )
            if done[0] + done[1] == 0:
                break
            collapsed += int(done[0])
            flipped += int(done[1])
            keep = ~dead
            changed = changed[keep]
            f, lock, hold, worst = f[keep], lock[keep], hold[keep], worst[keep]
            made = made[keep] | changed
            worst[changed] = smallest_angles(v[f[changed]])
            retry = _two_rings(f, changed, len(v))
    used = np.zeros(len(v), dtype=bool)
    used[f.reshape(-1)] = True
    index = np.cumsum(used) - 1
    left = int((worst < min_angle_deg).sum())
    return Desliver(
        v[used], index[f], None if locked is None else lock, made, collapsed, flipped, left
    )


def _two_rings(
    faces: IntArray, changed: npt.NDArray[np.bool_], n_vertices: int
) -> npt.NDArray[np.bool_]:
    """Mark the triangles within two rings of the vertices of the `changed` ones."""
    near = np.zeros(n_vertices, dtype=bool)
    near[faces[changed].reshape(-1)] = True
    for _ in range(2):
        ring = near[faces].any(axis=1)
        near[faces[ring].reshape(-1)] = True
    out: npt.NDArray[np.bool_] = np.asarray(near[faces].any(axis=1))
    return out


@kernel
def _round(
    v: FloatArray,
    faces: IntArray,
    worst: FloatArray,
    touched: npt.NDArray[np.bool_],
    changed: npt.NDArray[np.bool_],
    dead: npt.NDArray[np.bool_],
    order: IntArray,
    start: IntArray,
    slivers: IntArray,
    max_move: float,
    cos_turn: float,
    flips: bool,
) -> IntArray:  # pragma: no cover - compiled
    """Make one round of moves, worst sliver first, on triangles no move touched yet.

    Caps are flipped only where `flips` is true (otherwise only needles are collapsed).

    `faces` and `v` change in place (a cap's corner moves); `touched`, `changed` and
    `dead` mark the triangles a move touched (their stars), made or changed, and dropped.
    Returns the collapses and flips made, (2,) int64.
    """
    done = np.zeros(2, dtype=np.int64)
    for i in range(len(slivers)):
        t = slivers[i]
        if touched[t]:
            continue
        shortest = 0
        best = np.inf
        for j in range(3):
            length = _distance(v[faces[t, j]], v[faces[t, (j + 1) % 3]])
            if length < best:
                best = length
                shortest = j
        u, w = faces[t, shortest], faces[t, (shortest + 1) % 3]
        # Of the edge's two collapses, the one that moves the surface less first (a vertex
        # on a crease stays where it is and the other comes to it).
        gap_uw = _collapse_gap(v, faces, touched, order, start, u, w, max_move)
        gap_wu = _collapse_gap(v, faces, touched, order, start, w, u, max_move)
        if gap_wu < gap_uw:
            u, w = w, u
            gap_uw, gap_wu = gap_wu, gap_uw
        if gap_uw <= max_move and _collapse(
            v, faces, worst, touched, changed, dead, order, start, u, w, cos_turn
        ):
            done[0] += 1
            continue
        if gap_wu <= max_move and _collapse(
            v, faces, worst, touched, changed, dead, order, start, w, u, cos_turn
        ):
            done[0] += 1
            continue
        if not flips:
            continue
        widest = 0
        angle = -1.0
        for j in range(3):
            a = _angle(v[faces[t, j]], v[faces[t, (j + 1) % 3]], v[faces[t, (j + 2) % 3]])
            if a > angle:
                angle = a
                widest = j
        # a cap: flip the edge opposite its wide corner
        if angle > 0.5 * np.pi and _flip(
            v, faces, worst, touched, changed, order, start, t, widest, max_move, cos_turn
        ):
            done[1] += 1
    return done


@kernel(inline="always")
def _distance(p: FloatArray, q: FloatArray) -> float:  # pragma: no cover - compiled
    return float(np.sqrt((p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 + (p[2] - q[2]) ** 2))


@kernel(inline="always")
def _angle(p: FloatArray, q: FloatArray, r: FloatArray) -> float:  # pragma: no cover - compiled
    """Return the angle (radians) at `p` of the triangle p q r."""
    u = q - p
    w = r - p
    c = _cross3(u, w)
    return float(np.arctan2(np.sqrt(c[0] ** 2 + c[1] ** 2 + c[2] ** 2), np.dot(u, w)))


@kernel(inline="always")
def _cross3(u: FloatArray, w: FloatArray) -> FloatArray:  # pragma: no cover - compiled
    out = np.empty(3)
    out[0] = u[1] * w[2] - u[2] * w[1]
    out[1] = u[2] * w[0] - u[0] * w[2]
    out[2] = u[0] * w[1] - u[1] * w[0]
    return out


@kernel
def _smallest_angle(p: FloatArray, q: FloatArray, r: FloatArray) -> float:  # pragma: no cover
    """Return the smallest angle (radians) of the triangle p q r."""
    return min(_angle(p, q, r), _angle(q, r, p), _angle(r, p, q))


@kernel
def _has(faces: IntArray, f: int, vertex: int) -> bool:  # pragma: no cover - compiled
    return bool(faces[f, 0] == vertex or faces[f, 1] == vertex or faces[f, 2] == vertex)


@kernel
def _any_touched(touched: npt.NDArray[np.bool_], star: IntArray) -> bool:  # pragma: no cover
    return bool(touched[star].any())


@kernel
def _collapse_gap(
    v: FloatArray,
    faces: IntArray,
    touched: npt.NDArray[np.bool_],
    order: IntArray,
    start: IntArray,
    u: int,
    w: int,
    max_move: float,
) -> float:  # pragma: no cover - compiled
    """How far moving `u` onto `w` moves the surface (inf where it may not be made).

    Not where the stars of `u` or `w` were touched this round or the link condition
    fails; the distance is the largest of `u` from the planes of the triangles it changes.
    """
    star_u = order[start[u] : start[u + 1]]
    star_w = order[start[w] : start[w + 1]]
    if _any_touched(touched, star_u) or _any_touched(touched, star_w):
        return np.inf
    opposite = np.full(2, -1, dtype=np.int64)
    n_edge = 0
    for f in star_u:
        if _has(faces, f, w):
            if n_edge == 2:
                return np.inf
            for k in range(3):
                x = faces[f, k]
                if x != u and x != w:
                    opposite[n_edge] = x
            n_edge += 1
    if n_edge != 2 or opposite[0] == opposite[1]:
        return np.inf
    # the link condition: the vertices next to both are the edge's two opposite ones
    for f in star_u:
        for k in range(3):
            x = faces[f, k]
            if x in (u, w, opposite[0], opposite[1]):
                continue
            for g in star_w:
                if _has(faces, g, x):
                    return np.inf
    gap = 0.0
    for f in star_u:
        if _has(faces, f, w):
            continue
        corners = v[faces[f]].copy()
        for k in range(3):
            if faces[f, k] == u:
                corners[k] = v[w]
        n = _cross3(corners[1] - corners[0], corners[2] - corners[0])
        size = np.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
        if size == 0.0:
            return np.inf
        gap = max(gap, abs(np.dot(n, v[u] - v[w])) / size)
    return gap


@kernel
def _better(
    before: FloatArray, after: FloatArray, worst: float, cos_turn: float
) -> bool:  # pragma: no cover - compiled
    """Whether triangles `after` ((n, 3, 3) mm) may replace `before`, row for row.

    None turns past the limit or loses its area, and the smallest angle of `after` beats
    `worst` (degrees, the smallest of every triangle the move changes or removes).
    """
    smallest = np.inf
    for i in range(len(after)):
        n0 = _cross3(before[i, 1] - before[i, 0], before[i, 2] - before[i, 0])
        n1 = _cross3(after[i, 1] - after[i, 0], after[i, 2] - after[i, 0])
        size = np.sqrt(np.dot(n0, n0) * np.dot(n1, n1))
        if not size > 0.0 or np.dot(n0, n1) < cos_turn * size:
            return False
        smallest = min(smallest, _smallest_angle(after[i, 0], after[i, 1], after[i, 2]))
    return bool(np.degrees(smallest) > worst)


@kernel
def _collapse(
    v: FloatArray,
    faces: IntArray,
    worst: FloatArray,
    touched: npt.NDArray[np.bool_],
    changed: npt.NDArray[np.bool_],
    dead: npt.NDArray[np.bool_],
    order: IntArray,
    start: IntArray,
    u: int,
    w: int,
    cos_turn: float,
) -> bool:  # pragma: no cover - compiled
    """Move `u` onto `w` (checked by :func:`_collapse_gap`) if it makes no worse sliver."""
    star_u = order[start[u] : start[u + 1]]
    star_w = order[start[w] : start[w + 1]]
    moving = np.array([f for f in star_u if not _has(faces, f, w)], dtype=np.int64)
    before = np.empty((len(moving), 3, 3))
    after = np.empty((len(moving), 3, 3))
    region = np.inf
    for f in star_u:
        region = min(region, worst[f])
    for i in range(len(moving)):
        for k in range(3):
            x = faces[moving[i], k]
            before[i, k] = v[x]
            after[i, k] = v[w] if x == u else v[x]
    if not _better(before, after, region, cos_turn):
        return False
    for f in star_u:
        if _has(faces, f, w):
            dead[f] = True
        else:
            for k in range(3):
                if faces[f, k] == u:
                    faces[f, k] = w
            changed[f] = True
        touched[f] = True
    for f in star_w:
        touched[f] = True
    return True


@kernel
def _flip(
    v: FloatArray,
    faces: IntArray,
    worst: FloatArray,
    touched: npt.NDArray[np.bool_],
    changed: npt.NDArray[np.bool_],
    order: IntArray,
    start: IntArray,
    t: int,
    widest: int,
    max_move: float,
    cos_turn: float,
) -> bool:  # pragma: no cover - compiled
    """Flip the edge of triangle `t` opposite its corner `widest` with the neighbour there.

    When the flip moves the surface too far, the wide corner moves onto the edge (to its
    foot point, as far as the cap is high) and the flip follows: the two new triangles
    then lie in the neighbour's plane.
    """
    c = faces[t, widest]
    a = faces[t, (widest + 1) % 3]
    b = faces[t, (widest + 2) % 3]
    s = -1
    for f in order[start[a] : start[a + 1]]:
        if f != t and _has(faces, f, b):
            if s >= 0:
                return False
            s = f
    if s < 0 or touched[s]:
        return False
    d = -1
    for k in range(3):
        if faces[s, k] != a and faces[s, k] != b:
            d = faces[s, k]
    star_c = order[start[c] : start[c + 1]]
    star_d = order[start[d] : start[d + 1]]
    if _any_touched(touched, star_c) or _any_touched(touched, star_d):
        return False
    for f in star_c:
        if _has(faces, f, d):  # the new edge is there already
            return False
    # t is (a, b, c) turned, s holds b -> a: the new pair is (c, a, d) and (d, b, c)
    before = np.empty((2, 3, 3))
    after = np.empty((2, 3, 3))
    for k in range(3):
        before[0, k] = v[faces[t, k]]
        before[1, k] = v[faces[s, k]]
    rows = np.array([[c, a, d], [d, b, c]], dtype=np.int64)
    for i in range(2):
        for k in range(3):
            after[i, k] = v[rows[i, k]]
    region = min(worst[t], worst[s])
    # The two triangulations of the quad a c b d meet at its corners and part most where
    # the diagonals pass each other: by the distance of the lines ab and cd.
    across = _cross3(v[b] - v[a], v[d] - v[c])
    size = np.sqrt(np.dot(across, across))
    flat = size > 0.0 and abs(np.dot(v[c] - v[a], across)) / size <= max_move
    if flat and _better(before, after, region, cos_turn):
        faces[t] = rows[0]
        faces[s] = rows[1]
        touched[t] = touched[s] = True
        changed[t] = changed[s] = True
        return True
    edge = v[b] - v[a]
    squared = np.dot(edge, edge)
    if squared == 0.0:
        return False
    share = min(max(np.dot(v[c] - v[a], edge) / squared, 0.0), 1.0)
    foot = v[a] + share * edge
    if not _distance(v[c], foot) <= max_move:
        return False
    rest = np.array([f for f in star_c if f != t], dtype=np.int64)
    before = np.empty((len(rest) + 1, 3, 3))
    after = np.empty((len(rest) + 1, 3, 3))
    for i in range(len(rest)):
        for k in range(3):
            x = faces[rest[i], k]
            before[i, k] = v[x]
            after[i, k] = foot if x == c else v[x]
    for k in range(3):
        before[len(rest), k] = v[faces[s, k]]
    after[len(rest), 0] = foot
    after[len(rest), 1] = v[a]
    after[len(rest), 2] = v[d]
    second = np.empty((1, 3, 3))
    second[0, 0] = v[d]
    second[0, 1] = v[b]
    second[0, 2] = foot
    for f in star_c:
        region = min(region, worst[f])
    # the second new triangle replaces t: compared with the neighbour's plane, as t is a cap
    if not (
        _better(before, after, region, cos_turn)
        and _better(before[len(rest) :], second, region, cos_turn)
    ):
        return False
    v[c] = foot
    faces[t] = rows[0]
    faces[s] = rows[1]
    for f in star_c:
        touched[f] = True
        changed[f] = True
    touched[s] = changed[s] = True
    return True
