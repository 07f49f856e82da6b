"""Guarded simplification of nested closed shells: an error bound, then a no-crossing check.

The shells meshed from the layer field (``shellvox.offset.field.layer_field``) carry about nine
triangles per grid step squared of surface where they are curved (their planar patches are
triangulated from their boundaries): millions on a 100 mm part. They are simplified
by Manifold's edge collapse (``manifold3d``, ``Manifold.simplify(tolerance)``: the result
keeps a subset of the vertices, stays closed and 2-manifold, and no surface moves by more
than the tolerance), then once more at a quarter of the tolerance (a tidy pass that removes
most slivers and folds the first leaves), and the result is accepted only when

* every shell's error against its target depth, ``|d - D_k(f)|`` with the exact nearest
  face, stays within ``GuardLimits`` (the maximum at the vertices, the face centroids and
  area-weighted samples; the 99th percentile over the samples, within its share of ``D``),
  or within the unsimplified shell's own error plus how far the passes may move the
  surface (``(1 + TIDY + SLIVER_MOVE)`` times the tolerance) where the grid alone
  exceeds a limit (the p99 over its samples; past the maximum, its largest error near each
  such point, or its error at the point's nearest point plus the distance to it: the
  creases of a faceted input, which a finer ``--shell-step`` sharpens), and
  and, for a layer whose faces have several depths (a build's colour-driven depths), where
  the field jumps between two depths and ``|d - D(f)|`` measures the jump, not a distance,
  every shell lies within those limits of its unsimplified shell instead (the distance
  between the two, sampled both ways: the maximum within ``GuardLimits.max_error_mm``, the
  99th percentile within its share of the layer's smallest depth, or within the tolerance
  the passes may move it; Manifold's collapses of edges shorter than the tolerance can add
  up past it), and
* no two triangles of the shells cross
  (:func:`shellvox.offset.crossing.intersections.intersecting_pairs` over all shells
  together, so a shell crossing a neighbouring one counts too), and no
  shell is pinched (two of its vertices at one place: Manifold keeps a collapse that makes
  the surface touch itself 2-manifold that way, a non-manifold vertex once welded).

Manifold's edge collapse can fold a few triangles over a neighbour around a sliver (4 pairs
in 15 M triangles of spot at 100 mm), or pinch a shell (the bunny's inner one at 50 mm).
Where the shells cross or pinch, the unsimplified triangles near there are locked (each
its own ``face_id``: Manifold keeps every edge between triangles of different ids) and
the shell is simplified again, so the first pass keeps
the unsimplified triangles there, which cross nothing by construction (so does the tidy
pass that follows; the crossing check covers its result); the lock's radius is twice the
longest edge of the crossing triangles, doubled on each of ``GuardLimits.lock_rounds``,
plus the reach of a triangle from its centroid to its farthest corner.

The simplified vertices are then moved by at most 1e-8 of the part's size (seed 0), which
breaks the exact coplanarity of flat parts that MeshLab's triangle test misreads (see
:mod:`shellvox.offset.reference.for_file`); both checks run on the moved vertices, and where the
move makes a crossing (two triangles within the move of each other) their vertices go back.
Shells without crossings or pinches then lose their slivers
(:func:`shellvox.offset.field.simplify_passes.without_slivers`: collapses and flips that
each move the surface by at most ``SLIVER_MOVE`` times the tolerance, kept only where the
triangles they made cross nothing), and the error bound is checked on the result.
Otherwise the tolerance is quartered and the shells simplified again from the originals; when every
try fails the unsimplified shells are kept (they are valid by construction), less their
slivers where the sliver pass (moves of at most ``SLIVER_MOVE`` times the first tolerance)
makes no crossing or pinch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.field.heap import heap_blocks
from shellvox.offset.field.simplify_passes import (
    LOG,
    SLIVER_MOVE,
    TIDY,
    Mesh,
    crossing_free,
    without_slivers,
)
from shellvox.voxel.geometry._nearest import SurfaceIndex, nearest_faces, nearest_on_surface

#: Triangles per chunk of a pass over an unsimplified shell.
CHUNK = 1 << 20

#: Area-weighted samples of a shell for its error percentiles.
SAMPLES = 200_000


@dataclass(frozen=True)
class GuardLimits:
    """Tolerances of the guarded simplification (mm).

    Attributes
    ----------
    tolerance_mm : float
        First tolerance handed to Manifold's simplification.
    max_error_mm : float
        Largest ``|d - D|`` allowed at a vertex or a face centroid of a simplified shell
        (in a layer of several depths: its largest distance to the unsimplified shell).
    p99_error_share : float
        Largest 99th percentile of ``|d - D| / D`` allowed (in a layer of several depths:
        of the distance to the unsimplified shell over the layer's smallest depth).
    tries : int
        Simplifications tried (the tolerance is quartered between tries).
    lock_rounds : int
        Simplifications of a try again with the triangles near crossings locked.
    """

    tolerance_mm: float = 0.002
    max_error_mm: float = 0.05
    p99_error_share: float = 0.005
    tries: int = 3
    lock_rounds: int = 3


#: The default limits.
DEFAULT_LIMITS = GuardLimits()


class Simplified(NamedTuple):
    """Shells after the guarded simplification and what it did.

    Attributes
    ----------
    meshes : list of (vertices (V, 3) float64 mm, faces (T, 3) int64)
        The shells, outside in.
    record : dict
        ``tolerance_mm`` used (0: kept unsimplified), ``tries``, ``faces_before``,
        ``faces_after``, ``raw_error_mm`` and ``error_mm`` (p99 and max of ``|d - D|`` per
        shell, before and after), ``guard`` per shell (``"depth"``: ``|d - D|`` against
        the limits; ``"unsimplified shell"``: a layer of several depths, measured by
        ``unsimplified_distance_mm``, the p99 and max distance to its unsimplified shell,
        null for the others), ``crossing_pairs`` of the last try,
        ``lock_rounds`` of the last try and ``locked_faces`` per shell (unsimplified
        triangles kept around crossings); ``attempts``: the tolerance, crossing pairs, lock
        rounds and error of every try.
    crossing_free : bool
        The shells, as returned and all together, were tested and no two of their
        triangles cross (:func:`shellvox.offset.crossing.intersections.intersecting_pairs`); False
        for shells kept unsimplified (crossing-free by construction, not tested here).
    """

    meshes: list[Mesh]
    record: dict[str, Any]
    crossing_free: bool = False


def simplify_shells(
    meshes: list[Mesh],
    surface: SurfaceIndex,
    depth_mm: FloatArray,
    *,
    limits: GuardLimits = DEFAULT_LIMITS,
) -> Simplified:
    """Simplify closed shells under an error bound and a no-crossing check.

    Parameters
    ----------
    meshes : list of (vertices (V, 3) float64 mm, faces (T, 3) int64)
        Closed, outward-oriented, nested shells (empty where a layer fills the part).
    surface : SurfaceIndex
        The original surface.
    depth_mm : (K, F) float64, mm
        Target depth of each shell per original face.
    limits : GuardLimits, optional

    Returns
    -------
    Simplified
    """
    with heap_blocks():
        return _simplify_shells(meshes, surface, depth_mm, limits)


def _simplify_shells(
    meshes: list[Mesh], surface: SurfaceIndex, depth_mm: FloatArray, limits: GuardLimits
) -> Simplified:
    """:func:`simplify_shells`, with large blocks from the heap (:mod:`~.field.heap`)."""
    before = [len(f) for _, f in meshes]
    raw = [
        _depth_error(surface, depth_mm[k], v, f, samples_only=True)
        for k, (v, f) in enumerate(meshes)
    ]
    # a layer of several depths is measured against its unsimplified shell
    several = [len(f) > 0 and bool(np.ptp(depth_mm[k]) > 0) for k, (_, f) in enumerate(meshes)]
    unsimplified = [
        SurfaceIndex.build(v, f) if s else None for (v, f), s in zip(meshes, several, strict=True)
    ]
    record: dict[str, Any] = {
        "faces_before": before,
        "tries": 0,
        "raw_error_mm": [[e.p99, e.max] for e in raw],
        "guard": ["unsimplified shell" if s else "depth" for s in several],
        "attempts": [],
    }
    tolerance = limits.tolerance_mm
    for attempt in range(limits.tries):
        record["tries"] = attempt + 1
        candidate, locked, crossings, slivers = crossing_free(meshes, tolerance, limits.lock_rounds)
        errors = [_depth_error(surface, depth_mm[k], v, f) for k, (v, f) in enumerate(candidate)]
        moved = (1.0 + TIDY + SLIVER_MOVE) * tolerance
        apart: list[list[float] | None] = [None] * len(meshes)
        within = True
        for k, (e, r) in enumerate(zip(errors, raw, strict=True)):
            index = unsimplified[k]
            if index is None:
                within = within and _within(e, r, limits, moved, surface, depth_mm[k], meshes[k])
                continue
            p99, far = _apart(e.points, r.points, index, candidate[k])
            apart[k] = [p99, far]
            share = limits.p99_error_share * float(depth_mm[k].min())
            within = within and p99 <= max(share, moved) and far <= max(limits.max_error_mm, moved)
        record.update(
            crossing_pairs=crossings,
            slivers=slivers,
            lock_rounds=locked.rounds,
            locked_faces=[int(lock.sum()) for lock in locked.faces],
            error_mm=[[e.p99, e.max] for e in errors],
            unsimplified_distance_mm=apart,
        )
        record["attempts"].append(
            {
                "tolerance_mm": tolerance,
                "crossing_pairs": crossings,
                "lock_rounds": locked.rounds,
                "error_mm": record["error_mm"],
                "unsimplified_distance_mm": apart,
                "within": within,
            }
        )
        LOG.debug("try %d: %s", attempt + 1, record["attempts"][-1])
        if within and crossings == 0:
            record.update(tolerance_mm=tolerance, faces_after=[len(f) for _, f in candidate])
            return Simplified(candidate, record, crossing_free=True)
        tolerance /= 4.0
    # Unsimplified: still without their slivers where that makes no crossing or pinch.
    shells, slivers = without_slivers(
        meshes, [None] * len(meshes), SLIVER_MOVE * limits.tolerance_mm
    )
    record.update(tolerance_mm=0.0, faces_after=[len(f) for _, f in shells], slivers=slivers)
    return Simplified(shells, record)


def _apart(
    points: FloatArray, raw_points: FloatArray, unsimplified: SurfaceIndex, shell: Mesh
) -> tuple[float, float]:
    """Return the p99 and the maximum distance between a shell and its unsimplified one (mm).

    The shell's `points` ((N, 3), mm: the area-weighted samples first, then its vertices and
    centroids) are measured to the unsimplified shell, and `raw_points` ((M, 3), mm: samples
    of the unsimplified shell) to the shell; the p99 is over the shell's samples, the maximum
    over both ways.
    """
    _, there = nearest_faces(unsimplified, points)
    _, back = nearest_faces(SurfaceIndex.build(*shell), raw_points)
    return float(np.percentile(there[:SAMPLES], 99)), float(max(there.max(), back.max()))


def _within(
    error: _Error,
    raw: _Error,
    limits: GuardLimits,
    tolerance_mm: float,
    surface: SurfaceIndex,
    depth: FloatArray,
    original: Mesh,
) -> bool:
    """Return whether a simplified shell's error is within the limits.

    Each bound may be exceeded by what the grid alone gives (the creases of a faceted
    input, rounded off by the grid) plus `tolerance_mm`, how far the simplification may
    move the surface: the p99 by the unsimplified shell's own p99, a point past the maximum
    by the unsimplified shell's largest error near it (:func:`_raw_error_near`) or, where
    those samples fall short, by the error at the point's nearest point of the unsimplified
    shell plus the distance to it (:func:`_raw_error_at_nearest`); a point further than
    `tolerance_mm` from the unsimplified shell is not within them.
    """
    p99 = error.p99_share <= limits.p99_error_share or error.p99 <= raw.p99 + tolerance_mm
    if not p99:
        return False
    over = error.error > max(limits.max_error_mm, raw.max + tolerance_mm)
    if not over.any():
        return True
    points, measured = error.points[over], error.error[over]
    near = _raw_error_near(surface, depth, original, points)
    fine = measured <= near + tolerance_mm
    if fine.all():
        return True
    exact = _raw_error_at_nearest(surface, depth, original, points[~fine], tolerance_mm)
    # infinite where the point moved further than the tolerance: nothing vouches for it
    return bool((np.isfinite(exact) & (measured[~fine] <= exact)).all())


def _raw_error_at_nearest(
    surface: SurfaceIndex, depth: FloatArray, original: Mesh, points: FloatArray, moved: float
) -> FloatArray:
    """Return the error a point may have, from the unsimplified shell's nearest point (mm).

    For each point ``p`` ((P, 3), mm) of a simplified shell, ``q`` is the nearest point of
    the unsimplified shell; the distance to the surface is 1-Lipschitz, so ``p``'s error is
    at most ``q``'s error plus ``|p - q|``: that sum is returned ((P,) float64), or
    infinity where ``|p - q|`` exceeds `moved` (the simplification moved the surface
    further than its tolerance). The samples of :func:`_raw_error_near` can miss ``q``'s
    error by a little on a long unsimplified triangle across a crease.
    """
    v, f = original
    # a triangle within `moved` of a point has its corners within this of the point
    hit = _faces_near(original, points, moved + _longest_edge(original))
    if not hit.any():
        return np.full(len(points), np.inf)
    local = SurfaceIndex.build(v, f[hit])
    found = nearest_on_surface(local, points)
    corners = v[local.faces[found.face_ids]]
    nearest = np.einsum("pk,pkc->pc", found.barycentric, corners)
    gap = found.distance_mm
    face, distance = nearest_faces(surface, nearest)
    bound = np.abs(distance - depth[face]) + gap
    return np.asarray(np.where(gap <= moved, bound, np.inf), dtype=np.float64)


def _longest_edge(mesh: Mesh) -> float:
    """Return the longest edge of a mesh (mm), in chunks of ``CHUNK`` triangles."""
    v, f = mesh
    return max(
        float(np.linalg.norm(v[f[i : i + CHUNK, j]] - v[f[i : i + CHUNK, j - 1]], axis=1).max())
        for i in range(0, len(f), CHUNK)
        for j in range(3)
    )


def _raw_error_near(
    surface: SurfaceIndex, depth: FloatArray, original: Mesh, points: FloatArray
) -> FloatArray:
    """Return the unsimplified shell's largest ``|d - D|`` near each point (mm).

    The error is taken at the corners, edge midpoints and centroid of every unsimplified
    triangle with a corner in a cell (of twice the longest edge) around a point, and its
    maximum over those within that distance of the point is returned ((P,) float64).
    """
    v, f = original
    reach = 2.0 * _longest_edge(original)
    corners = v[f[_faces_near(original, points, reach)]]
    mids = (corners + np.roll(corners, 1, axis=1)) / 2.0
    samples = np.concatenate(
        [corners.reshape(-1, 3), mids.reshape(-1, 3), corners.mean(axis=1)], axis=0
    )
    face, distance = nearest_faces(surface, samples)
    sample_error = np.abs(distance - depth[face])
    gap, index = cKDTree(samples).query(points, k=64, distance_upper_bound=reach)
    found = np.isfinite(gap)
    padded = np.append(sample_error, 0.0)
    return np.asarray(np.where(found, padded[np.minimum(index, len(samples))], 0.0).max(axis=1))


def _faces_near(mesh: Mesh, points: FloatArray, reach: float) -> npt.NDArray[np.bool_]:
    """Mark the triangles ((T,) bool) with a corner in a cell (side `reach`, mm) by a point's.

    Every triangle with a corner within `reach` of a point is marked, and some further.
    """
    v, f = mesh
    keys = np.floor(v / reach).astype(np.int64)
    around = np.floor(points / reach).astype(np.int64)
    steps = np.array(list(np.ndindex(3, 3, 3))) - 1
    wanted = np.unique((around[:, None, :] + steps[None]).reshape(-1, 3), axis=0)
    return np.asarray(_rows_in(keys, wanted)[f].any(axis=1))


def _rows_in(rows: IntArray, wanted: IntArray) -> npt.NDArray[np.bool_]:
    """Return which of the integer rows ((N, 3)) are among `wanted` ((M, 3))."""
    lo = np.minimum(rows.min(axis=0), wanted.min(axis=0))
    span = np.maximum(rows.max(axis=0), wanted.max(axis=0)) - lo + 1

    def code(r: IntArray) -> IntArray:
        c = r - lo
        return np.asarray((c[:, 0] * span[1] + c[:, 1]) * span[2] + c[:, 2], dtype=np.int64)

    return np.isin(code(rows), code(wanted))


class _Error(NamedTuple):
    """A shell's ``|d - D(f)|``: summaries (mm, or a share of ``D``) and where it was taken."""

    p99: float
    max: float
    p99_share: float
    points: FloatArray
    error: FloatArray


def _depth_error(
    surface: SurfaceIndex,
    depth: FloatArray,
    vertices: FloatArray,
    faces: IntArray,
    *,
    samples_only: bool = False,
) -> _Error:
    """Return ``|d - D(f)|`` of a shell: p99 and max (mm), p99 of ``|d - D| / D``.

    The maximum is over the vertices, the face centroids and the samples; the percentiles
    over ``SAMPLES`` points spread by area (seed 0), so large flat triangles weigh as much
    as the many small ones along a crease. With `samples_only` (the unsimplified shells,
    tens of millions of triangles) the maximum is over the samples alone. ``points``
    ((N, 3), mm) and ``error`` ((N,), mm) are every point measured.
    """
    if len(faces) == 0:
        return _Error(0.0, 0.0, 0.0, np.zeros((0, 3)), np.zeros(0))
    tri = vertices[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    rng = np.random.default_rng(0)
    chosen = rng.choice(len(faces), SAMPLES, p=area / area.sum())
    weights = rng.dirichlet(np.ones(3), SAMPLES)
    samples = np.einsum("ni,nij->nj", weights, tri[chosen])
    points = samples if samples_only else np.concatenate([samples, vertices, tri.mean(axis=1)])
    face, distance = nearest_faces(surface, points)
    target = depth[face]
    error = np.abs(distance - target)
    return _Error(
        float(np.percentile(error[:SAMPLES], 99)),
        float(error.max()),
        float(np.percentile(error[:SAMPLES] / target[:SAMPLES], 99)),
        points,
        error,
    )
