"""The guard's bound at a point from the unsimplified shell's nearest point, analytically."""

from __future__ import annotations

import sys

import numpy as np
import trimesh

from shellvox.offset.field.simplify import _raw_error_at_nearest
from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface


def test_a_point_off_an_exact_inset_may_err_by_its_distance_to_it(monkeypatch):
    # The unsimplified shell is the exact 0.5 mm inset of a 10 mm cube (no error of its
    # own, subdivided so it has many triangles); points above its faces, moved outward by
    # delta, lie 0.5 - delta deep: their error is delta, and the bound is exactly that.
    cube = trimesh.creation.box((10.0, 10.0, 10.0))
    inset = trimesh.creation.box((9.0, 9.0, 9.0)).subdivide().subdivide()
    surface = SurfaceIndex.build(np.asarray(cube.vertices), np.asarray(cube.faces, np.int64))
    depth = np.full(len(cube.faces), 0.5)
    rng = np.random.default_rng(1)
    delta = np.array([0.0005, 0.001, 0.002, 0.0029, 0.004])
    at = np.column_stack([rng.uniform(-4.0, 4.0, (5, 2)), np.full(5, 4.5)])  # the top face
    points = at + np.column_stack([np.zeros((5, 2)), delta])
    true_error = np.abs(distance_to_surface(surface, points) - 0.5)
    np.testing.assert_allclose(true_error, delta, atol=1e-12)
    original = (np.asarray(inset.vertices), np.asarray(inset.faces, np.int64))
    # rtree, which trimesh's proximity queries need, is no dependency of shellvox: the bound
    # must not import it.
    monkeypatch.setitem(sys.modules, "rtree", None)
    bound = _raw_error_at_nearest(surface, depth, original, points, moved=0.003)
    np.testing.assert_allclose(bound[:4], true_error[:4], atol=1e-12)
    assert np.isinf(bound[4])  # moved further than the tolerance: nothing vouches for it


def test_a_point_over_the_maximum_that_moved_past_the_tolerance_is_refused():
    # A simplified point 0.06 mm above the exact inset's top face errs by 0.06 mm, over the
    # 0.05 mm maximum; the unsimplified shell is exact and 0.06 mm away, further than the
    # simplification may move (0.003 mm): nothing vouches for the point.
    from shellvox.offset.field.simplify import DEFAULT_LIMITS, _Error, _within

    cube = trimesh.creation.box((10.0, 10.0, 10.0))
    inset = trimesh.creation.box((9.0, 9.0, 9.0)).subdivide().subdivide()
    surface = SurfaceIndex.build(np.asarray(cube.vertices), np.asarray(cube.faces, np.int64))
    depth = np.full(len(cube.faces), 0.5)
    original = (np.asarray(inset.vertices), np.asarray(inset.faces, np.int64))
    exact = _Error(0.0, 0.0, 0.0, np.zeros((0, 3)), np.zeros(0))

    def within(point):
        error = np.abs(distance_to_surface(surface, point[None]) - 0.5)
        measured = _Error(0.0, float(error.max()), 0.0, point[None], error)
        return _within(measured, exact, DEFAULT_LIMITS, 0.003, surface, depth, original)

    assert not within(np.array([1.0, -2.0, 4.5 + 0.06]))
    assert within(np.array([1.0, -2.0, 4.5 + 0.04]))  # under the maximum


def test_a_layer_of_several_depths_is_measured_against_its_unsimplified_shell(monkeypatch):
    # A subdivided 10 mm cube, its upper half 0.5 mm deep and its lower half 1.0 mm: the
    # field jumps at z = 0, where |d - D| of the marched shell reaches the 0.5 mm jump (its
    # p99 is 0.37 mm), so |d - D| cannot tell a shell in place from one moved. The
    # "simplification" here translates the unsimplified shell by `shift` along z: its
    # distance to the unsimplified shell is `shift` everywhere, analytically. Within what
    # the passes may move at the first tolerance ((1 + 0.25 + 1) x 0.002 mm) it is
    # accepted; moved 0.03 mm (p99 over) or 0.08 mm (past the 0.05 mm maximum) it is not.
    from shellvox.offset.field import simplify
    from shellvox.offset.field.layer_field import field_surfaces
    from shellvox.offset.field.simplify_passes import Locks

    cube = trimesh.creation.box((10.0, 10.0, 10.0)).subdivide().subdivide()
    v, f = np.asarray(cube.vertices), np.asarray(cube.faces, np.int64)
    depth = np.where(cube.triangles_center[:, 2] > 0.0, 0.5, 1.0)[None]
    raw = field_surfaces(v, f, depth, 0.25).surfaces
    surface = SurfaceIndex.build(v, f)
    one_try = simplify.GuardLimits(tries=1)

    def result(shift):
        def translated(meshes, tolerance_mm, rounds):
            out = [(m[0] + np.array([0.0, 0.0, shift]), m[1]) for m in meshes]
            return out, Locks([np.zeros(len(m[1]), bool) for m in meshes], 0), 0, {}

        monkeypatch.setattr(simplify, "crossing_free", translated)
        return simplify.simplify_shells(raw, surface, depth, limits=one_try).record

    for shift in (0.0003, 0.003):
        record = result(shift)
        assert record["guard"] == ["unsimplified shell"]
        assert record["tolerance_mm"] == one_try.tolerance_mm  # accepted
        np.testing.assert_allclose(record["unsimplified_distance_mm"][0], shift, rtol=1e-6)
    for shift in (0.03, 0.08):
        record = result(shift)
        np.testing.assert_allclose(record["attempts"][0]["unsimplified_distance_mm"][0], shift)
        assert record["tolerance_mm"] == 0.0  # refused: kept unsimplified
    # one depth: the guard is |d - D| itself
    assert simplify.simplify_shells(
        field_surfaces(v, f, np.full_like(depth, 0.5), 0.25).surfaces,
        surface,
        np.full_like(depth, 0.5),
        limits=one_try,
    ).record["guard"] == ["depth"]
