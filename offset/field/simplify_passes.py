"""Manifold's simplification passes over closed shells, and the locks that undo its folds.

A pass is Manifold's edge collapse (``Manifold.simplify``) and then a tidy pass over its
result at ``TIDY`` of the tolerance. Where the shells still cross, the unsimplified
triangles near the crossing are locked (a ``face_id`` each) and the shell is simplified
again; see :mod:`shellvox.offset.field.simplify`, whose guard uses them. Shells that
cross nothing then lose their slivers (:func:`without_slivers`).
"""

from __future__ import annotations

import logging
from typing import Any, NamedTuple

import manifold3d
import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import smallest_angles
from shellvox.offset.crossing.intersections import JITTER_FRACTION, intersecting_pairs
from shellvox.offset.field.slivers import Desliver, remove_slivers

Mesh = tuple[FloatArray, IntArray]

LOG = logging.getLogger(__name__)

#: Tolerance of the tidy pass over a simplification, as a share of the first one's.
TIDY = 0.25

#: Largest move of the sliver pass after the tidy one, as a share of the first tolerance.
SLIVER_MOVE = 1.0

#: Rounds of putting back the jittered vertices of crossing triangles before the jitter is
#: dropped (each round is one crossing check of all the shells).
JITTER_REVERTS = 4

#: Largest move (mm) of the collapses the sliver pass makes in locked triangles: the
#: sub-micrometre vertex clusters a marched surface makes where it passes a grid node.
LOCKED_COLLAPSE_MM = 1e-5

#: Tries of those collapses, each keeping the triangles near the last try's crossings as
#: they are.
LOCKED_COLLAPSE_TRIES = 3

#: Reach (mm) around a crossing of those collapses within which the next try keeps the
#: input's triangles.
LOCKED_COLLAPSE_REACH_MM = 1e-3


class Locks(NamedTuple):
    """The unsimplified triangles locked per shell ((T,) bool) and the rounds that did it."""

    faces: list[npt.NDArray[np.bool_]]
    rounds: int


def crossing_free(
    meshes: list[Mesh], tolerance_mm: float, rounds: int
) -> tuple[list[Mesh], Locks, int, dict[str, Any]]:
    """Simplify the shells, locking the triangles near defects until there are none.

    The defects are crossing triangle pairs and pinches: Manifold keeps its result
    2-manifold where a collapse makes the surface touch itself at a vertex by splitting
    that vertex in two at the same place, which a reader that welds coincident vertices
    (MeshLab) reads as a non-manifold vertex. Shells without defects lose their slivers
    (:func:`without_slivers`).

    Returns the shells (jittered unless the jitter makes a crossing), the locks, the
    crossing pairs and faces at pinches left after the last round (0 when the shells are
    accepted), and the sliver pass's record (empty when the shells were not accepted).
    """
    locks = [np.zeros(len(f), dtype=bool) for _, f in meshes]
    passes = [simplified(v, f, tolerance_mm) for v, f in meshes]
    plain = [mesh for mesh, _ in passes]
    still = [lock for _, lock in passes]
    done = 0
    while True:
        candidate, pairs, owner = _jittered(plain)
        pinched = pinched_faces(plain)
        LOG.debug(
            "tolerance %g, lock round %d: %d crossing pairs, %d faces at pinches",
            tolerance_mm,
            done,
            len(pairs),
            len(pinched),
        )
        pairs = np.concatenate([pairs, np.stack([pinched, pinched], axis=1)])
        if len(pairs) == 0:
            shells, record = without_slivers(candidate, still, SLIVER_MOVE * tolerance_mm)
            return shells, Locks(locks, done), 0, record
        if done == rounds:
            return candidate, Locks(locks, done), len(pairs), {}
        for k in np.unique(owner[pairs]):
            near = _near_crossings(candidate, pairs, owner, meshes[int(k)], 2.0**done)
            if (near & ~locks[k]).any():
                locks[k] |= near
                v, f = meshes[int(k)]
                plain[k], still[k] = simplified(v, f, tolerance_mm, locked=locks[k])
        done += 1


def without_slivers(
    shells: list[Mesh], locked: list[npt.NDArray[np.bool_] | None], move_mm: float
) -> tuple[list[Mesh], dict[str, Any]]:
    """Remove the slivers of crossing-free shells where that makes no crossing.

    Each shell goes through :func:`shellvox.offset.field.slivers.remove_slivers` (moves of
    at most `move_mm`); the triangles the moves made are then tested against all of the
    shells' (the others are as they were: they cross nothing) and for pinches. The first
    try moves every triangle; where it makes a crossing, the second keeps the `locked`
    ones (the unsimplified triangles kept around the simplification's folds) as they are
    but for collapses of needles that move the surface by at most ``LOCKED_COLLAPSE_MM``;
    where those make a crossing, the triangles within ``LOCKED_COLLAPSE_REACH_MM`` of it
    are kept as they are and it is tried again, ``LOCKED_COLLAPSE_TRIES`` times at most,
    then without those collapses; where that crosses too, the shells are returned as given.
    After the second try the shells are jittered again (:func:`_jittered`): the jitter
    before was put back at the clusters, which left their flat neighbours exactly coplanar
    for MeshLab's triangle test; where the new jitter still crosses after its reverts, the
    shells stay as the sliver pass left them.

    Returns the shells and a record: ``collapsed``, ``flipped`` and ``left`` (slivers)
    per shell, ``min_angle_deg`` per shell, and ``kept``: ``"all"`` (the first try),
    ``"unlocked"`` (the second) or ``"none"``.
    """
    tries: list[tuple[str, list[npt.NDArray[np.bool_] | None]]] = [("all", [None] * len(shells))]
    if any(lock is not None and lock.any() for lock in locked):
        tries.append(("unlocked", locked))
    for name, locks in tries:
        fixed: list[npt.NDArray[np.bool_] | None] = [None] * len(shells)
        collapses = [LOCKED_COLLAPSE_MM] * LOCKED_COLLAPSE_TRIES if name == "unlocked" else []
        for collapse_mm in [*collapses, 0.0]:
            out = [
                remove_slivers(
                    v, f, move_mm, locked=lock, locked_collapse_mm=collapse_mm, fixed=fix
                )
                for (v, f), lock, fix in zip(shells, locks, fixed, strict=True)
            ]
            moved = [(o.vertices, o.faces) for o in out]
            pairs, _ = crossings(moved, only=np.concatenate([o.changed for o in out]))
            pinched = pinched_faces(moved)
            LOG.debug(
                "sliver pass (%s, locked collapses %g mm): %d crossing pairs, %d pinched",
                name,
                collapse_mm,
                len(pairs),
                len(pinched),
            )
            if len(pairs) == 0 and len(pinched) == 0:
                if name == "unlocked":  # the jitter reverted at the clusters, again
                    again, pairs, _ = _jittered(moved)
                    if len(pairs) == 0 and len(pinched_faces(again)) == 0:
                        moved = again
                return moved, _sliver_record(moved, out, name)
            if collapse_mm == 0.0:
                break
            fixed = _near_faces(shells, moved, np.concatenate([pairs.reshape(-1), pinched]), fixed)
    return shells, _sliver_record(shells, out, "none")


def _near_faces(
    shells: list[Mesh],
    moved: list[Mesh],
    bad: IntArray,
    fixed: list[npt.NDArray[np.bool_] | None],
) -> list[npt.NDArray[np.bool_] | None]:
    """Add to `fixed` the triangles of `shells` near the `bad` faces of `moved`.

    `bad` indexes the faces of `moved`, concatenated outside in; a triangle of a shell is
    near when a corner is within ``LOCKED_COLLAPSE_REACH_MM`` of a corner of a bad face of
    that shell.
    """
    start = np.cumsum([0] + [len(f) for _, f in moved])
    out: list[npt.NDArray[np.bool_] | None] = []
    for k, ((v, f), (mv, mf)) in enumerate(zip(shells, moved, strict=True)):
        mine = bad[(bad >= start[k]) & (bad < start[k + 1])] - start[k]
        near = np.zeros(len(f), dtype=bool) if fixed[k] is None else np.array(fixed[k])
        if len(mine):
            corners = mv[np.unique(mf[mine])]
            gap, _ = cKDTree(corners).query(v, distance_upper_bound=LOCKED_COLLAPSE_REACH_MM)
            near |= np.isfinite(gap)[f].any(axis=1)
        out.append(near)
    return out


def _sliver_record(shells: list[Mesh], out: list[Desliver], kept: str) -> dict[str, Any]:
    """Return the record of :func:`without_slivers`."""
    return {
        "kept": kept,
        "collapsed": [o.collapsed for o in out],
        "flipped": [o.flipped for o in out],
        "left": [o.left for o in out],
        "min_angle_deg": [
            float(smallest_angles(v[f]).min()) if len(f) else None for v, f in shells
        ],
    }


def _jittered(plain: list[Mesh]) -> tuple[list[Mesh], IntArray, IntArray]:
    """Return the shells jittered where the jitter makes no crossing, and their crossings.

    The vertices of triangles that cross after the jitter go back to their places and the
    shells are checked again, up to ``JITTER_REVERTS`` times (a vertex put back can make a
    crossing with a neighbour still moved: the faceted spot at 100 mm needs two). Each
    check after the first tests only the pairs with a triangle that moved back; the others
    are as they were. When every crossing triangle is back in place, the crossings are the
    simplification's own (a fold) and are returned as they are; when the rounds run out
    first, the unjittered shells are checked. Dropping the whole jitter for a few crossings
    would leave every flat part exactly coplanar, which MeshLab's triangle test reads as
    crossings at random (261 faces of spot's outer shell at 100 mm).
    """
    moved = [_jitter(v, f) for v, f in plain]
    still = [np.ones(len(v), dtype=bool) for v, _ in plain]  # vertices still jittered
    pairs, owner = crossings(moved)
    start = np.cumsum([0] + [len(f) for _, f in plain])
    for _ in range(JITTER_REVERTS):
        if len(pairs) == 0:
            return moved, pairs, owner
        changed = np.zeros(len(owner), dtype=bool)
        faces = np.unique(pairs)
        for k in np.unique(owner[faces]):
            local = faces[owner[faces] == k] - start[k]
            corners = plain[k][1][local]
            back = np.unique(corners[still[k][corners]])
            if len(back) == 0:
                continue
            v = moved[k][0].copy()
            v[back] = plain[k][0][back]
            moved[k] = (v, plain[k][1])
            still[k][back] = False
            touched = np.zeros(len(v), dtype=bool)
            touched[back] = True
            changed[start[k] : start[k + 1]] = touched[plain[k][1]].any(axis=1)
        if not changed.any():  # the crossing triangles are where the simplification put them
            return moved, pairs, owner
        kept = pairs[~changed[pairs].any(axis=1)]
        new, owner = crossings(moved, only=changed)
        pairs = np.unique(np.concatenate([kept, new]), axis=0)
    if len(pairs) == 0:
        return moved, pairs, owner
    pairs, owner = crossings(plain)
    return plain, pairs, owner


def pinched_faces(meshes: list[Mesh]) -> IntArray:
    """Return the faces, concatenated outside in, at a vertex that shares its position.

    Two vertices of one shell at exactly one position are a pinch (see :func:`crossing_free`).
    """
    vertices, faces = _concatenated(meshes)
    if len(vertices) == 0:
        return np.zeros(0, dtype=np.int64)
    start = np.cumsum([0] + [len(v) for v, _ in meshes])
    shell = np.searchsorted(start, np.arange(len(vertices)), side="right") - 1
    keyed = np.column_stack([shell.astype(np.float64), vertices])
    _, first, count = np.unique(keyed, axis=0, return_inverse=True, return_counts=True)
    shared = count[np.asarray(first).reshape(-1)] > 1
    if not shared.any():
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(shared[faces].any(axis=1)).astype(np.int64)


def _near_crossings(
    shells: list[Mesh],
    pairs: IntArray,
    owner: IntArray,
    original: Mesh,
    scale: float,
) -> npt.NDArray[np.bool_]:
    """Mark the triangles of `original` near the crossing triangles of `pairs`.

    A triangle is near when its centroid lies within ``2 * scale`` times the longest edge of
    the crossing triangles, plus the distance from its centroid to its farthest corner,
    from one of their corners.
    """
    vertices, faces = _concatenated(shells)
    corners = vertices[faces[np.unique(pairs)]]
    longest = float(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max())
    radius = 2.0 * scale * longest
    points = corners.reshape(-1, 3)
    v, f = original
    lo, hi = points.min(axis=0) - radius, points.max(axis=0) + radius
    # A centroid in the box needs a corner on either side of each of its planes.
    below = np.zeros((len(f), 3), dtype=bool)
    above = np.zeros((len(f), 3), dtype=bool)
    for j in range(3):
        corner = v[f[:, j]]
        below |= corner <= hi
        above |= corner >= lo
    box = np.all(below & above, axis=1)
    near = np.zeros(len(f), dtype=bool)
    candidates = np.flatnonzero(box)
    corners = v[f[candidates]]
    centroid = corners.mean(axis=1)
    # Within the radius of the triangle's farthest corner from its centroid too: a long
    # triangle (a planar patch's) passes by a crossing far from its centroid.
    spread = np.linalg.norm(corners - centroid[:, None, :], axis=2).max(axis=1)
    distance, _ = cKDTree(points).query(centroid)
    near[candidates] = distance <= radius + spread
    return near


def simplified(
    vertices: FloatArray,
    faces: IntArray,
    tolerance_mm: float,
    *,
    locked: npt.NDArray[np.bool_] | None = None,
) -> tuple[Mesh, npt.NDArray[np.bool_] | None]:
    """Return Manifold's simplification of a closed mesh, then a tidy pass over the result.

    The tidy pass (a new Manifold of the result, simplified at ``TIDY`` of the tolerance)
    swaps and collapses the slivers the first one leaves, and with them most of its folds
    (on the faceted spot at 100 mm: 49 crossing pairs before, 2 after); the surface moves
    by less than ``(1 + TIDY)`` times the tolerance in all. The `locked` triangles stay
    locked in the tidy pass too (it could fold them again: the airplane at 100 mm, around
    the long triangles of a planar patch); which triangles of the result they are is
    returned with it (None when none were locked).
    """
    once, still = _manifold_simplify(vertices, faces, tolerance_mm, locked)
    return _manifold_simplify(*once, TIDY * tolerance_mm, still)


def manifold_simplify(
    vertices: FloatArray,
    faces: IntArray,
    tolerance_mm: float,
    *,
    locked: npt.NDArray[np.bool_] | None = None,
) -> Mesh:
    """Return Manifold's simplification of a closed mesh (an empty mesh stays empty).

    Each `locked` triangle ((T,) bool) gets a ``face_id`` of its own, so every edge
    between two of them stays and they come out unsimplified.
    """
    return _manifold_simplify(vertices, faces, tolerance_mm, locked)[0]


def _manifold_simplify(
    vertices: FloatArray,
    faces: IntArray,
    tolerance_mm: float,
    locked: npt.NDArray[np.bool_] | None,
) -> tuple[Mesh, npt.NDArray[np.bool_] | None]:
    """:func:`manifold_simplify`, and which triangles of the result are locked ones."""
    if len(faces) == 0:
        return (vertices, faces), locked
    ids = {}
    if locked is not None and locked.any():
        ids["face_id"] = np.where(locked, np.arange(1, len(faces) + 1), 0).astype(np.uint64)
    mesh = manifold3d.Mesh64(
        vert_properties=np.ascontiguousarray(vertices, dtype=np.float64),
        tri_verts=np.ascontiguousarray(faces, dtype=np.uint64),
        **ids,
    )
    solid = manifold3d.Manifold(mesh)
    if solid.status() != manifold3d.Error.NoError:
        raise ValueError(f"the shell is not a closed 2-manifold: Manifold says {solid.status()}")
    out = solid.simplify(tolerance_mm).to_mesh64()
    v = np.array(np.asarray(out.vert_properties)[:, :3], dtype=np.float64, order="C")
    f = np.ascontiguousarray(np.asarray(out.tri_verts), dtype=np.int64)
    still = np.asarray(out.face_id) > 0 if ids else None
    return (v, f), still


def _jitter(vertices: FloatArray, faces: IntArray) -> Mesh:
    """Move every vertex by at most ``JITTER_FRACTION`` of the extent (seed 0).

    The simplification leaves exactly coplanar neighbours on flat parts, which a triangle
    test without a coplanar tolerance (MeshLab's) reads as crossings at random; the
    crossing check runs on the moved vertices.
    """
    if len(vertices) == 0:
        return vertices, faces
    amplitude = JITTER_FRACTION * float(np.ptp(vertices, axis=0).max())
    move = np.random.default_rng(0).uniform(-amplitude, amplitude, vertices.shape)
    return vertices + move, faces


def crossings(
    meshes: list[Mesh], *, only: npt.NDArray[np.bool_] | None = None
) -> tuple[IntArray, IntArray]:
    """Return the crossing triangle pairs of the shells, all together, and each face's shell.

    `only` ((T,) bool over the concatenated faces) restricts the test to the pairs with a
    face in it (:func:`shellvox.offset.crossing.intersections.intersecting_pairs`).

    Returns
    -------
    pairs : (P, 2) int64
        Indices into the shells' faces, concatenated outside in.
    owner : (T,) int64
        The shell of every concatenated face.
    """
    vertices, faces = _concatenated(meshes)
    owner = np.repeat(np.arange(len(meshes)), [len(f) for _, f in meshes])
    if len(faces) == 0:
        return np.zeros((0, 2), dtype=np.int64), owner
    return intersecting_pairs(vertices, faces, only=only), owner


def _concatenated(meshes: list[Mesh]) -> Mesh:
    """Return the shells as one mesh, their faces concatenated outside in."""
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    vertices = np.concatenate([v for v, _ in meshes])
    faces = np.concatenate([f + offsets[k] for k, (_, f) in enumerate(meshes)])
    return vertices, faces
