from __future__ import annotations

import pickle

import numpy as np
import pytest
import trimesh

from shellvox.voxel.geometry import (
    SurfaceIndex,
    closest_barycentric,
    distance_to_surface,
    nearest_faces,
    nearest_on_surface,
)


def _brute(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance to every triangle by dense sampling + exact per-pair routine from trimesh."""
    n, f = len(points), len(triangles)
    closest = trimesh.triangles.closest_point(
        np.repeat(triangles[None], n, axis=0).reshape(-1, 3, 3), np.repeat(points, f, axis=0)
    )
    return np.linalg.norm(closest - np.repeat(points, f, axis=0), axis=1).reshape(n, f).min(axis=1)


def test_matches_brute_force():
    rng = np.random.default_rng(1)
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=5.0)
    # uneven triangle sizes stress the safe radius
    mesh.vertices += rng.normal(scale=0.3, size=mesh.vertices.shape)
    points = rng.uniform(-7, 7, size=(500, 3))
    index = SurfaceIndex.build(mesh.vertices, mesh.faces.astype(np.int64))
    hit = nearest_on_surface(index, points)
    np.testing.assert_allclose(hit.distance_mm, _brute(mesh.triangles, points), atol=1e-9)
    closest = np.einsum("nc,nck->nk", hit.barycentric, mesh.triangles[hit.face_ids])
    np.testing.assert_allclose(np.linalg.norm(closest - points, axis=1), hit.distance_mm)
    assert np.all(hit.barycentric >= -1e-12)
    np.testing.assert_allclose(hit.barycentric.sum(axis=1), 1.0)
    # the cheap halves agree with the brute force too
    face_ids, distance = nearest_faces(index, points)
    np.testing.assert_allclose(distance, _brute(mesh.triangles, points), atol=1e-9)
    np.testing.assert_array_equal(face_ids, hit.face_ids)
    np.testing.assert_array_equal(distance_to_surface(index, points), distance)


def test_barycentric_regions_against_trimesh():
    rng = np.random.default_rng(2)
    triangles = rng.normal(size=(2000, 3, 3))
    points = rng.normal(scale=2.0, size=(2000, 3))
    bary = closest_barycentric(points, triangles)
    mine = np.einsum("nc,nck->nk", bary, triangles)
    theirs = trimesh.triangles.closest_point(triangles, points)
    np.testing.assert_allclose(mine, theirs, atol=1e-9)


def test_box_with_few_big_faces():
    box = trimesh.creation.box(extents=(10.0, 20.0, 30.0))
    points = np.array([[0.0, 0.0, 14.0], [4.9, 0.0, 0.0], [20.0, 20.0, 20.0]])
    hit = nearest_on_surface(SurfaceIndex.build(box.vertices, box.faces.astype(np.int64)), points)
    np.testing.assert_allclose(hit.distance_mm, [1.0, 0.1, np.linalg.norm([15.0, 10.0, 5.0])])


def test_pickles_to_an_equal_index():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=5.0)
    index = SurfaceIndex.build(mesh.vertices, mesh.faces.astype(np.int64))
    again = pickle.loads(pickle.dumps(index))
    points = np.random.default_rng(3).uniform(-6, 6, size=(200, 3))
    np.testing.assert_array_equal(
        nearest_on_surface(again, points).distance_mm, nearest_on_surface(index, points).distance_mm
    )


def test_bad_input():
    index = SurfaceIndex.build(np.eye(3), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="points_mm must be"):
        nearest_on_surface(index, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="faces must be"):
        SurfaceIndex.build(np.eye(3), np.zeros((0, 3), np.int64))
