"""Shell guards (shellvox.offset.reference.guards) on shells whose defects are known by
construction."""

from __future__ import annotations

import numpy as np
import trimesh

from shellvox.offset.crossing.intersections import count_self_intersections
from shellvox.offset.reference.guards import Surface, too_deep, too_deep_count


def _box(size: float) -> tuple[np.ndarray, np.ndarray]:
    box = trimesh.creation.box((size, size, size))
    return np.asarray(box.vertices, dtype=np.float64), np.asarray(box.faces, dtype=np.int64)


def test_exact_inner_box_is_neither_deep_nor_crossing():
    v, f = _box(10.0)
    shell_v, shell_f = _box(9.0)  # every face 0.5 mm inside
    surface = Surface(v, f)
    assert surface.n_crossing == 0
    assert too_deep_count(surface, np.full(len(f), 0.5), shell_v, shell_f) == 0
    assert count_self_intersections(shell_v, shell_f) == 0


def test_a_face_cut_deeper_than_asked_is_counted():
    v, f = _box(10.0)
    shell_v, shell_f = _box(9.0)
    shell_v = shell_v.copy()
    shell_v[shell_v[:, 2] > 0, 2] = 3.0  # the top face 2 mm deep instead of 0.5 mm
    normals = trimesh.Trimesh(shell_v, shell_f, process=False).face_normals
    deep = too_deep_count(Surface(v, f), np.full(len(f), 0.5), shell_v, shell_f)
    # The two top triangles' centroids are 2 mm deep; the side triangles touching the
    # top have centroids between 0.5 and 2 mm deep along z but 0.5 mm from their side.
    assert deep == int(np.count_nonzero(normals[:, 2] > 0.5))


def test_variable_depth_is_not_a_defect():
    v, f = _box(10.0)
    depth = np.full(len(f), 0.5)
    normals = trimesh.Trimesh(v, f, process=False).face_normals
    depth[normals[:, 2] > 0.5] = 2.0  # the top layer is thicker
    shell_v, shell_f = _box(9.0)
    shell_v = shell_v.copy()
    shell_v[shell_v[:, 2] > 0, 2] = 3.0
    assert too_deep_count(Surface(v, f), depth, shell_v, shell_f) == 0


def test_too_deep_matches_brute_force_nearest_face():
    # Points inside a crumpled sphere, variable depth: deep exactly when the distance to
    # the surface (brute force over every face, trimesh's per-triangle closest point)
    # exceeds the largest depth around the nearest face. Points where nearly tied faces
    # would disagree are left out.
    rng = np.random.default_rng(3)
    sphere = trimesh.creation.icosphere(2, 10.0)
    v = np.asarray(sphere.vertices) * rng.uniform(0.9, 1.1, (len(sphere.vertices), 1))
    f = np.asarray(sphere.faces, dtype=np.int64)
    depth = rng.uniform(0.5, 2.0, len(f))
    points = v[rng.integers(0, len(v), 400)] * rng.uniform(0.6, 1.0, (400, 1))
    points += rng.normal(0.0, 0.5, points.shape)
    shell_f = np.arange(3 * len(points)).reshape(-1, 3)  # degenerate: centroid = point
    shell_v = np.repeat(points, 3, axis=0)
    got = too_deep(Surface(v, f), depth, shell_v, shell_f)

    tri = v[f]
    query = np.repeat(points, len(f), axis=0)  # point-major: every point against every face
    closest = trimesh.triangles.closest_point(np.tile(tri, (len(points), 1, 1)), query)
    dist = np.linalg.norm(closest - query, axis=1).reshape(len(points), len(f))
    vdepth = np.zeros(len(v))
    np.maximum.at(vdepth, f.reshape(-1), np.repeat(depth, 3))
    allowed_face = vdepth[f].max(axis=1)
    nearest = dist.min(axis=1)
    tied = dist <= nearest[:, None] + 1e-9
    deep_any = np.any(tied & (nearest[:, None] > 1.001 * allowed_face), axis=1)
    deep_all = np.all(~tied | (nearest[:, None] > 1.001 * allowed_face), axis=1)
    clear = deep_any == deep_all
    assert np.count_nonzero(clear) > 300
    assert 50 < np.count_nonzero(deep_all[clear]) < np.count_nonzero(clear) - 50
    np.testing.assert_array_equal(got[clear], deep_all[clear])
