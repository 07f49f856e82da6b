"""Coplanar triangles in shell files: what MeshLab flags, and the jitter that clears it.

Truths: exact rational arithmetic (fractions) for the triangles MeshLab misjudges,
MeshLab itself (pymeshlab, when installed) and the exact coplanarity test of
shellvox.offset.crossing.intersections.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import trimesh
from meshlab_process import needs_meshlab
from scipy.spatial.transform import Rotation

from shellvox.offset.crossing.intersections import coplanar_pairs, count_self_intersections
from shellvox.offset.reference.jitter import JITTER_FRACTION, jitter_vertices
from shellvox.output import write_ply
from shellvox.testing import meshlab_checks, meshlab_crossing_faces


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def _sub(a, b):
    return [x - y for x, y in zip(a, b, strict=True)]


def _exactly_separated(t0, t1):
    """Whether a plane through an edge of one triangle, perpendicular to it, has that
    triangle on one side and the other strictly on the other (exact arithmetic)."""
    for s, t in ((t0, t1), (t1, t0)):
        p = [[Fraction(float(x)) for x in q] for q in s]
        other = [[Fraction(float(x)) for x in q] for q in t]
        normal = _cross(_sub(p[1], p[0]), _sub(p[2], p[0]))
        for k in range(3):
            a, b, c = p[k], p[(k + 1) % 3], p[(k + 2) % 3]
            out = _cross(_sub(b, a), normal)  # in the plane of s, across edge a-b
            side = _dot(out, _sub(c, a))
            if all(_dot(out, _sub(q, a)) * side < 0 for q in other):
                return True
    return False


# Two triangles of one face of a rotated, subdivided box (float64 as printed by numpy).
COPLANAR_PAIR = np.array(
    [
        [18.72823671271265, 25.091696296856977, 37.64603039551898],
        [17.86123647876913, 23.781861127990943, 40.10217420742079],
        [17.050206297315256, 23.67831077590412, 38.84459424202948],
        [20.350297075620393, 25.298797001030632, 40.161190326301586],
        [18.672266660223, 23.88541148007777, 41.35975417281209],
        [19.53926689416652, 25.195246648943805, 38.90361036091028],
    ]
)


@needs_meshlab
def test_meshlab_flags_two_disjoint_coplanar_triangles():
    # The cause of MeshLab's flags on robust shells, in two triangles: their planes
    # agree to round-off, their boxes overlap, an exact separating plane exists, and
    # MeshLab (vcg's NoDivTriTriIsect, whose coplanarity tolerance is never compiled
    # in) reports both as self-intersecting.
    t0, t1 = COPLANAR_PAIR[:3], COPLANAR_PAIR[3:]
    assert _exactly_separated(t0, t1)
    assert np.all((t0.min(axis=0) < t1.max(axis=0)) & (t1.min(axis=0) < t0.max(axis=0)))
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    assert meshlab_crossing_faces(COPLANAR_PAIR, faces, merge_duplicates=False) == 2


def _rotated_box(subdivisions):
    box = trimesh.creation.box((10.0, 8.0, 6.0))
    for _ in range(subdivisions):
        box = box.subdivide()
    rotation = Rotation.from_euler("xyz", [0.3, 0.5, 0.7])
    offset = np.array([20.0, 30.0, 40.0])
    return rotation.apply(box.vertices) + offset, np.asarray(box.faces, np.int64)


@needs_meshlab
def test_jitter_clears_meshlab_flags_of_coplanar_faces(tmp_path):
    v, f = _rotated_box(3)  # 768 faces on 6 planes, none axis-aligned
    write_ply(tmp_path / "box.ply", v, f)
    assert meshlab_checks(tmp_path / "box.ply")["self_intersecting_faces"] > 0
    pairs = coplanar_pairs(v, f)
    assert len(pairs) > 0
    jittered = jitter_vertices(v, f)
    extent = float(np.ptp(v, axis=0).max())
    assert jittered.amplitude_mm == pytest.approx(JITTER_FRACTION * extent)
    assert jittered.n_kept == 0 and jittered.coplanar_pairs == 0
    # The vertices of coplanar pairs moved by the amplitude, the others not at all.
    moved = np.linalg.norm(jittered.vertices - v, axis=1)
    target = np.zeros(len(v), dtype=bool)
    target[f[pairs.reshape(-1)].reshape(-1)] = True
    assert jittered.n_moved == np.count_nonzero(target)
    np.testing.assert_allclose(moved[target], jittered.amplitude_mm, rtol=1e-6)
    assert np.all(moved[~target] == 0)
    write_ply(tmp_path / "jittered.ply", jittered.vertices, f)
    seen = meshlab_checks(tmp_path / "jittered.ply")
    assert seen["self_intersecting_faces"] == 0
    assert seen["two_manifold"] and seen["boundary_edges"] == 0
    assert count_self_intersections(jittered.vertices, f) == 0
    # Each point of the surface moved by at most the amplitude.
    volume = trimesh.Trimesh(jittered.vertices, f, process=False).volume
    assert abs(volume - 480.0) <= jittered.amplitude_mm * 376.0


def test_jitter_leaves_a_mesh_without_coplanar_pairs_alone():
    ico = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(ico.vertices), np.asarray(ico.faces, dtype=np.int64)
    jittered = jitter_vertices(v, f)
    assert jittered.n_moved == 0 and jittered.amplitude_mm == 0.0
    assert np.array_equal(jittered.vertices, v)


def test_jitter_leaves_exact_axis_planes_exact():
    # An axis-aligned box's faces are coplanar pairs, but held exactly (z = 3, ...):
    # every test's plane distances are exact zeros there, so nothing moves.
    box = trimesh.creation.box((10.0, 8.0, 6.0)).subdivide().subdivide()
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    assert len(coplanar_pairs(v, f)) > 0
    jittered = jitter_vertices(v, f)
    assert jittered.n_moved == 0 and jittered.coplanar_pairs == 0
    assert np.array_equal(jittered.vertices, v)


def test_jitter_keeps_touching_solids_touching():
    # Two boxes sharing a face (as separate vertices), which cross when moved at random,
    # beside a third, apart: the vertices of the first two stay, the third's move.
    rotation = Rotation.from_euler("xyz", [0.3, 0.5, 0.7])
    a = trimesh.creation.box((2.0, 2.0, 2.0)).subdivide()
    b = a.copy().apply_translation((2.0, 0.0, 0.0))
    touching = trimesh.util.concatenate([a, b])
    v_touch = rotation.apply(touching.vertices) + 10.0
    f_touch = np.asarray(touching.faces, dtype=np.int64)
    v_apart, f_apart = _rotated_box(2)
    v = np.concatenate([v_touch, v_apart])
    f = np.concatenate([f_touch, f_apart + len(v_touch)])
    assert count_self_intersections(v, f) == 0
    amplitude = JITTER_FRACTION * float(np.ptp(v, axis=0).max())
    step = np.random.default_rng(0).normal(size=v_touch.shape)
    step *= amplitude / np.linalg.norm(step, axis=1, keepdims=True)
    assert count_self_intersections(v_touch + step, f_touch) > 0
    jittered = jitter_vertices(v, f, seed=0)
    assert jittered.amplitude_mm == pytest.approx(amplitude)
    assert count_self_intersections(jittered.vertices, f) == 0
    moved = np.linalg.norm(jittered.vertices - v, axis=1)
    # The shared face's corners stay; the apart box's coplanar pairs are resolved.
    x = (v_touch - 10.0) @ rotation.as_matrix()
    assert np.all(moved[: len(v_touch)][np.abs(x[:, 0] - 1.0) < 1e-9] == 0)
    assert jittered.n_kept > 0 and jittered.n_moved > 0
    np.testing.assert_allclose(moved[moved > 0], amplitude, rtol=1e-6)
    assert np.count_nonzero(moved[len(v_touch) :]) == jittered.n_moved
    assert len(coplanar_pairs(jittered.vertices[len(v_touch) :], f_apart)) == 0
