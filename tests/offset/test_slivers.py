"""The sliver pass of the field shells (offset/field/slivers.py).

Truths: trimesh's reading of the result (closed, oriented, its angles and volume), exact
point-to-surface distances (libigl), and surfaces whose slivers lie in planes (a move
that keeps them changes nothing of the solid).
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from shellvox.offset.adjacency import smallest_angles
from shellvox.offset.field.slivers import remove_slivers
from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface


def _slivered_box() -> trimesh.Trimesh:
    """A 10 mm cube, 16 x 16 squares a side, with needles and caps in its faces' planes.

    Thirty vertices inside the cube's faces, none next to another, each moved to within
    1e-4 of an edge's length of a neighbour (needles), and thirty more each moved to just
    inside the far edge of one of their triangles (caps, an angle near 180 degrees).
    """
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    for _ in range(4):
        box = box.subdivide()
    v = np.array(box.vertices)
    rng = np.random.default_rng(3)
    inner = np.flatnonzero((np.abs(v) < 4.99).sum(axis=1) == 2)  # off every edge of the cube
    taken = np.zeros(len(v), dtype=bool)
    chosen = []
    for i in rng.permutation(inner):
        if not taken[i]:
            chosen.append(int(i))
            taken[i] = True
            taken[box.vertex_neighbors[i]] = True
        if len(chosen) == 60:
            break
    faces = np.asarray(box.faces)
    for n, i in enumerate(chosen):
        p, q = (int(x) for x in faces[(faces == i).any(axis=1)][0] if x != i)
        if n < 30:  # a needle
            v[i] = v[p] + 1e-4 * (v[i] - v[p])
        else:  # a cap
            middle = 0.5 * (v[p] + v[q])
            v[i] = middle + 1e-4 * (v[i] - middle)
    return trimesh.Trimesh(v, faces, process=False)


def test_slivers_in_planes_go_and_the_solid_stays():
    box = _slivered_box()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, np.int64)
    before = smallest_angles(v[f])
    assert (before < 0.1).sum() >= 60  # needles and caps both
    out = remove_slivers(v, f, 0.002)
    result = trimesh.Trimesh(out.vertices, out.faces, process=False)
    assert result.is_watertight and result.is_winding_consistent
    assert out.left == 0
    assert smallest_angles(out.vertices[out.faces]).min() >= 1.0
    assert out.collapsed > 0 and out.flipped > 0
    np.testing.assert_allclose(result.volume, 1000.0, rtol=1e-12)
    # every vertex still on the cube
    on_cube = np.abs(np.abs(out.vertices).max(axis=1) - 5.0)
    assert on_cube.max() < 1e-12


def test_moves_on_a_sphere_stay_within_the_budget():
    # Needles on a curved surface: each collapse moves the surface by at most the budget;
    # measured both ways by exact distances at vertices and face centroids.
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=10.0)
    v = np.array(sphere.vertices)
    rng = np.random.default_rng(5)
    edges = sphere.edges_unique
    for e in edges[rng.choice(len(edges), 80, replace=False)]:
        v[e[0]] = v[e[1]] + rng.uniform(1e-3, 5e-3) * (v[e[0]] - v[e[1]])
    f = np.asarray(sphere.faces, np.int64)
    budget = 0.002
    out = remove_slivers(v, f, budget)
    assert out.collapsed > 0
    result = trimesh.Trimesh(out.vertices, out.faces, process=False)
    assert result.is_watertight and result.is_winding_consistent
    before, after = SurfaceIndex.build(v, f), SurfaceIndex.build(out.vertices, out.faces)
    samples_after = np.concatenate([out.vertices, out.vertices[out.faces].mean(axis=1)])
    samples_before = np.concatenate([v, v[f].mean(axis=1)])
    assert distance_to_surface(before, samples_after).max() <= budget
    assert distance_to_surface(after, samples_before).max() <= budget
    worse = smallest_angles(v[f])
    better = smallest_angles(out.vertices[out.faces])
    assert (better < 1.0).sum() < (worse < 1.0).sum()


def test_locked_triangles_stay_as_they_are():
    box = _slivered_box()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, np.int64)
    locked = np.zeros(len(f), dtype=bool)
    locked[: len(f) // 2] = True
    out = remove_slivers(v, f, 0.002, locked=locked)
    assert out.locked is not None
    kept = out.vertices[out.faces[out.locked]]
    np.testing.assert_array_equal(
        np.sort(kept.reshape(len(kept), -1), axis=0),
        np.sort(v[f[locked]].reshape(int(locked.sum()), -1), axis=0),
    )
    assert out.collapsed + out.flipped > 0  # the free half lost its slivers


def test_a_sliver_pass_that_makes_a_crossing_is_tried_with_the_locks_then_dropped(monkeypatch):
    # The crossing test is the guard: a first try that moves locked triangles and crosses
    # is tried again with them kept; when that crosses too, the shells come back as given.
    from shellvox.offset.field import simplify_passes

    box = _slivered_box()
    shell = (np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    locked = np.zeros(len(shell[1]), dtype=bool)
    locked[: len(locked) // 2] = True
    seen = []

    def crossing_on(tries_that_cross):
        def fake(meshes, only=None):
            if only is None:  # the jitter's check after the second try: no crossing
                return np.zeros((0, 2), dtype=np.int64), np.zeros(len(meshes[0][1]), np.int64)
            seen.append(only.copy())
            crosses = len(seen) in tries_that_cross
            pairs = np.array([[0, 1]]) if crosses else np.zeros((0, 2), dtype=np.int64)
            return pairs, np.zeros(len(meshes[0][1]), dtype=np.int64)

        return fake

    monkeypatch.setattr(simplify_passes, "crossings", crossing_on({1}))
    (out,), record = simplify_passes.without_slivers([shell], [locked], 0.002)
    assert record["kept"] == "unlocked" and len(seen) == 2
    assert seen[0].sum() > seen[1].sum() > 0  # fewer triangles made with the locks kept
    # every locked triangle is there as it was, but for the jitter after the second try
    kept_rows = out[0][out[1]].reshape(-1, 9)
    gap, _ = cKDTree(kept_rows).query(shell[0][shell[1][locked]].reshape(-1, 9))
    assert gap.max() <= 3 * 2 * simplify_passes.JITTER_FRACTION * 10.0
    assert record["min_angle_deg"][0] == smallest_angles(out[0][out[1]]).min()

    seen.clear()
    tries = simplify_passes.LOCKED_COLLAPSE_TRIES + 2  # all, locked collapses, unlocked
    monkeypatch.setattr(simplify_passes, "crossings", crossing_on(set(range(1, tries + 1))))
    (out,), record = simplify_passes.without_slivers([shell], [locked], 0.002)
    assert record["kept"] == "none" and len(seen) == tries
    assert out[0] is shell[0] and out[1] is shell[1]


def test_shells_kept_unsimplified_lose_their_slivers_too(monkeypatch):
    # Every simplification refused (a fake crossing in each try): the shells come back
    # unsimplified, through the sliver pass, and within its move of the originals.
    from shellvox.offset.field import simplify
    from shellvox.offset.field.simplify_passes import SLIVER_MOVE

    box = _slivered_box()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, np.int64)
    monkeypatch.setattr(simplify, "crossing_free", lambda m, t, r: (m, _NoLocks(m), 1, {}))
    depth = np.full((1, len(f)), 0.5)
    limits = simplify.GuardLimits(tries=2)
    out = simplify.simplify_shells([(v, f)], SurfaceIndex.build(v, f), depth, limits=limits)
    record = out.record
    assert record["tolerance_mm"] == 0.0 and record["tries"] == 2
    assert record["slivers"]["kept"] == "all" and record["slivers"]["left"] == [0]
    ((sv, sf),) = out.meshes
    result = trimesh.Trimesh(sv, sf, process=False)
    assert result.is_watertight and result.is_winding_consistent
    assert smallest_angles(sv[sf]).min() >= 1.0 > smallest_angles(v[f]).min()
    assert record["faces_after"] == [len(sf)] and len(sf) < len(f)
    budget = SLIVER_MOVE * limits.tolerance_mm
    samples = np.concatenate([sv, sv[sf].mean(axis=1)])
    assert distance_to_surface(SurfaceIndex.build(v, f), samples).max() <= budget


class _NoLocks:
    """The locks of a try that locked nothing."""

    def __init__(self, meshes):
        self.faces = [np.zeros(len(f), dtype=bool) for _, f in meshes]
        self.rounds = 0


def _box_with_clusters(gap: float) -> tuple[np.ndarray, np.ndarray]:
    """The slivered box's needle ends moved to within `gap` (mm) of their neighbours.

    Marching leaves such clusters where the surface passes a grid node (fandisk's inner
    shell: 2,797 edges under 1e-6 mm in its locked triangles).
    """
    box = _slivered_box()
    v, f = np.array(box.vertices), np.asarray(box.faces, np.int64)
    edges = np.linalg.norm(v[f] - np.roll(v[f], 1, axis=1), axis=2)
    short = f[edges < 1e-3]  # the needles' short edges: (end, start) rows of a corner pair
    rolled = np.roll(f, 1, axis=1)[edges < 1e-3]
    for a, b in zip(short, rolled, strict=True):
        v[a] = v[b] + gap * (v[a] - v[b]) / np.linalg.norm(v[a] - v[b])
    return v, f


def test_sub_micrometre_needles_in_locked_triangles_collapse():
    v, f = _box_with_clusters(1e-7)
    edges = np.linalg.norm(v[f] - np.roll(v[f], 1, axis=1), axis=2)
    assert 0 < edges.min() < 1e-6
    locked = np.ones(len(f), dtype=bool)
    kept = remove_slivers(v, f, 0.002, locked=locked)
    assert kept.collapsed + kept.flipped == 0  # locks alone: nothing moves
    out = remove_slivers(v, f, 0.002, locked=locked, locked_collapse_mm=1e-5)
    result = trimesh.Trimesh(out.vertices, out.faces, process=False)
    assert result.is_watertight and result.is_winding_consistent
    assert out.collapsed == 30 and out.flipped == 0
    assert np.isclose(result.volume, 1000.0)
    short = np.linalg.norm(out.vertices[out.faces] - np.roll(out.vertices[out.faces], 1, 1), axis=2)
    assert short.min() > 1e-5
    # each vertex stays where it was (an end moves onto its neighbour)
    assert len(np.unique(np.concatenate([v, out.vertices]), axis=0)) == len(np.unique(v, axis=0))
    # triangles held fixed stay as they are, in both phases
    fixed = np.zeros(len(f), dtype=bool)
    fixed[: len(f) // 2] = True
    held = remove_slivers(v, f, 0.002, locked=locked, locked_collapse_mm=1e-5, fixed=fixed)
    rows = {tuple(r) for r in np.sort(held.vertices[held.faces].reshape(-1, 9), axis=1)}
    assert {tuple(r) for r in np.sort(v[f[fixed]].reshape(-1, 9), axis=1)} <= rows
    assert 0 < held.collapsed < 30


def test_locked_collapses_that_cross_are_tried_again_without_the_triangles_near(monkeypatch):
    from shellvox.offset.field import simplify_passes

    v, f = _box_with_clusters(1e-7)
    locked = np.ones(len(f), dtype=bool)
    seen = []

    def fake(meshes, only=None):
        if only is None:  # the jitter's check after the second try: no crossing
            return np.zeros((0, 2), dtype=np.int64), np.zeros(len(meshes[0][1]), np.int64)
        seen.append(only.copy())
        crosses = len(seen) in (1, 2)  # the first try, then the first locked collapses
        pairs = np.array([[0, 1]]) if crosses else np.zeros((0, 2), dtype=np.int64)
        return pairs, np.zeros(len(meshes[0][1]), dtype=np.int64)

    monkeypatch.setattr(simplify_passes, "crossings", fake)
    (out,), record = simplify_passes.without_slivers([(v, f)], [locked], 0.002)
    assert record["kept"] == "unlocked" and len(seen) == 3
    assert 0 < seen[2].sum() <= seen[1].sum()
    result = trimesh.Trimesh(out[0], out[1], process=False)
    assert result.is_watertight and result.is_winding_consistent


def test_locked_clusters_collapse_and_the_shell_is_jittered_again(monkeypatch):
    # The first try (every triangle free) is made to cross; the second collapses the
    # locked clusters with the real crossing check, then jitters the shell again.
    from shellvox.offset.crossing.intersections import count_self_intersections
    from shellvox.offset.field import simplify_passes
    from shellvox.testing import meshlab_crossing_faces

    v, f = _box_with_clusters(1e-7)
    real = simplify_passes.crossings
    calls = []

    def first_crosses(meshes, only=None):
        calls.append(only is not None)
        if len(calls) == 1:
            return np.array([[0, 1]]), np.zeros(len(meshes[0][1]), dtype=np.int64)
        return real(meshes, only=only)

    monkeypatch.setattr(simplify_passes, "crossings", first_crosses)
    (out,), record = simplify_passes.without_slivers([(v, f)], [np.ones(len(f), bool)], 0.002)
    sv, sf = out
    assert record["kept"] == "unlocked" and record["collapsed"] == [30]
    assert calls[-1] is False  # the jitter's check of the whole shell
    result = trimesh.Trimesh(sv, sf, process=False)
    assert result.is_watertight and result.is_winding_consistent
    assert np.linalg.norm(sv[sf] - np.roll(sv[sf], 1, axis=1), axis=2).min() > 1e-5
    amplitude = simplify_passes.JITTER_FRACTION * 10.0
    on_planes = np.isclose(np.abs(sv), 5.0, rtol=0, atol=2 * amplitude)
    assert on_planes.any(axis=1).all()  # every vertex within the jitter of the cube
    assert not (np.abs(sv) == 5.0).any()  # and none exactly on a face's plane
    assert count_self_intersections(sv, sf) == 0
    assert meshlab_crossing_faces(sv, sf) == 0
