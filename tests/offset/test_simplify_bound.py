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
