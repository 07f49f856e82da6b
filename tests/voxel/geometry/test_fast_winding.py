"""The fast generalised winding number against independent answers.

The references: the winding number of closed boxes and spheres known analytically (1
inside, 0 outside, summed over overlapping parts, -1 inside out), an exact brute-force
sum of the triangles' solid angles in numpy (slow, small meshes only), and libigl's
``winding_number`` (exact) and ``fast_winding_number`` (the same tree method, compiled
elsewhere, in single precision).
"""

from __future__ import annotations

import igl
import numpy as np
import pytest
import trimesh

from shellvox.voxel.geometry import WindingTree, fast_winding_numbers
from shellvox.voxel.geometry._fast_winding import LEAF_FACES, POINTS_PER_TASK

#: Largest error against the exact winding number at Barill et al.'s beta = 2 (measured:
#: 0.0058 on the sphere, 0.0042 on the teapot; libigl's 0.0024 and 0.0025), and at beta = 4.
TOLERANCE_BETA_2 = 1e-2
TOLERANCE_BETA_4 = 1e-3


def _exact(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Sum of the signed solid angles of every triangle / 4 pi (Van Oosterom-Strackee)."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]
    out = np.empty(len(points))
    for start in range(0, len(points), 128):  # slow reference: chunks of points
        p = points[start : start + 128, None, :]
        a, b, c = (tri[None, :, k, :] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("qfk,qfk->qf", a, np.cross(b, c))
        div = (
            la * lb * lc
            + np.einsum("qfk,qfk->qf", a, b) * lc
            + np.einsum("qfk,qfk->qf", b, c) * la
            + np.einsum("qfk,qfk->qf", c, a) * lb
        )
        out[start : start + 128] = 2.0 * np.arctan2(det, div).sum(axis=1) / (4.0 * np.pi)
    return out


def _box(low, high) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=[low, high])


def _in_box(points: np.ndarray, low, high, margin: float = 0.0) -> np.ndarray:
    return np.all((points > np.add(low, margin)) & (points < np.subtract(high, margin)), axis=1)


def _clear_of_box(points: np.ndarray, low, high, margin: float) -> np.ndarray:
    """Points farther than `margin` from every face of the box (inside or outside)."""
    return _in_box(points, low, high, margin) | ~_in_box(points, low, high, -margin)


def _arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def _teapot(shared_mesh) -> tuple[np.ndarray, np.ndarray]:
    mesh = trimesh.load(shared_mesh("teapot/teapot.obj"), force="mesh")
    assert not mesh.is_watertight  # open: the case the winding number is for
    return _arrays(mesh)


def test_closed_sphere_is_one_inside_zero_outside():
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=1.0)  # 5,120 faces
    vertices, faces = _arrays(mesh)
    points = np.random.default_rng(0).uniform(-1.5, 1.5, (20_000, 3))
    radius = np.linalg.norm(points, axis=1)
    # the polyhedron lies between the spheres of radii `inradius` and 1: none is tested there
    inradius = np.abs(np.einsum("fk,fk->f", mesh.triangles[:, 0], mesh.face_normals)).min()
    assert inradius > 0.99
    clear = (radius < 0.99) | (radius > 1.0)
    inside = (radius < 0.99)[clear]
    winding = fast_winding_numbers(vertices, faces, points)[clear]
    assert np.abs(winding - inside).max() < TOLERANCE_BETA_2
    tighter = WindingTree.build(vertices, faces).evaluate(points[clear], beta=4.0)
    assert np.abs(tighter - inside).max() < TOLERANCE_BETA_4
    np.testing.assert_array_equal(winding >= 0.5, inside)


def test_beta_zero_is_the_exact_sum():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    mesh.vertices += np.random.default_rng(1).normal(scale=0.05, size=mesh.vertices.shape)
    vertices, faces = _arrays(mesh)
    points = np.random.default_rng(2).uniform(-1.3, 1.3, (500, 3))
    exact = _exact(vertices, faces, points)
    tree = WindingTree.build(vertices, faces)
    np.testing.assert_allclose(tree.evaluate(points, beta=0.0), exact, rtol=0, atol=1e-12)
    assert np.abs(tree.evaluate(points) - exact).max() < TOLERANCE_BETA_2


def test_open_teapot_matches_exact_and_libigl(shared_mesh):
    vertices, faces = _teapot(shared_mesh)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    pad = 0.1 * (high - low)
    points = np.random.default_rng(3).uniform(low - pad, high + pad, (3000, 3))
    exact = _exact(vertices, faces, points)
    np.testing.assert_allclose(exact, igl.winding_number(vertices, faces, points), atol=1e-9)
    assert exact.max() > 1.5  # the spout and the handle overlap the body
    tree = WindingTree.build(vertices, faces)
    winding = tree.evaluate(points)
    libigl = igl.fast_winding_number(vertices, faces, points)
    assert np.abs(winding - exact).max() < TOLERANCE_BETA_2
    assert np.abs(winding - libigl).max() < TOLERANCE_BETA_2
    assert np.abs(tree.evaluate(points, beta=4.0) - exact).max() < TOLERANCE_BETA_4
    # the inside decision, away from the surface and from the level set w = 1/2
    distance = np.sqrt(igl.point_mesh_squared_distance(points, vertices, faces)[0])
    clear = (distance > 0.01 * (high - low).max()) & (np.abs(exact - 0.5) > TOLERANCE_BETA_2)
    assert clear.mean() > 0.9
    np.testing.assert_array_equal((winding >= 0.5)[clear], (exact >= 0.5)[clear])
    np.testing.assert_array_equal((winding >= 0.5)[clear], (libigl >= 0.5)[clear])


def test_overlapping_boxes_sum():
    a_low, a_high, b_low, b_high = (0, 0, 0), (2, 2, 2), (1, 0.5, 0.5), (3, 1.5, 2.5)
    soup = trimesh.util.concatenate([_box(a_low, a_high), _box(b_low, b_high)])
    vertices, faces = _arrays(soup)
    points = np.random.default_rng(4).uniform(-0.5, 3.5, (20_000, 3))
    in_a, in_b = _in_box(points, a_low, a_high), _in_box(points, b_low, b_high)
    expected = in_a.astype(float) + in_b
    clear = _clear_of_box(points, a_low, a_high, 0.02) & _clear_of_box(points, b_low, b_high, 0.02)
    winding = fast_winding_numbers(vertices, faces, points)
    assert np.abs(winding - expected)[clear].max() < TOLERANCE_BETA_2
    assert np.count_nonzero(expected[clear] == 2) > 300  # the overlap is sampled (1.5 of 64)


def test_flipped_box_is_minus_one_inside():
    low, high = (-1, -2, -0.5), (1, 2, 0.5)
    box = _box(low, high)
    vertices, faces = _arrays(box)
    points = np.random.default_rng(5).uniform(-2.5, 2.5, (10_000, 3))
    clear = _clear_of_box(points, low, high, 0.02)
    expected = -_in_box(points, low, high).astype(float)
    winding = fast_winding_numbers(vertices, faces[:, ::-1], points)
    assert np.abs(winding - expected)[clear].max() < TOLERANCE_BETA_2


def test_duplicated_faces_and_unshared_corners():
    low, high = (0, 0, 0), (1, 1, 1)
    vertices, faces = _arrays(_box(low, high))
    points = np.random.default_rng(6).uniform(-0.5, 1.5, (10_000, 3))
    clear = _clear_of_box(points, low, high, 0.02)
    inside = _in_box(points, low, high).astype(float)
    doubled = fast_winding_numbers(vertices, np.concatenate([faces, faces]), points)
    assert np.abs(doubled - 2 * inside)[clear].max() < TOLERANCE_BETA_2
    corners = vertices[faces].reshape(-1, 3)  # a soup: every triangle its own corners
    soup = fast_winding_numbers(corners, np.arange(len(corners)).reshape(-1, 3), points)
    assert np.abs(soup - inside)[clear].max() < TOLERANCE_BETA_2


def test_random_soup_matches_exact():
    rng = np.random.default_rng(7)
    centres = rng.uniform(0, 10, (300, 1, 3))
    corners = (centres + rng.normal(scale=1.0, size=(300, 3, 3))).reshape(-1, 3)
    faces = np.arange(len(corners)).reshape(-1, 3)
    points = rng.uniform(-1, 11, (1500, 3))
    exact = _exact(corners, faces, points)
    assert np.abs(fast_winding_numbers(corners, faces, points) - exact).max() < TOLERANCE_BETA_2


def test_one_tree_many_batches_any_order_any_threads():
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    tree = WindingTree.build(*_arrays(mesh))
    leaf_sizes = np.diff(tree.leaf_bounds)
    assert tree.depth > 5 and LEAF_FACES // 2 <= leaf_sizes.min() <= leaf_sizes.max() <= LEAF_FACES
    points = np.random.default_rng(8).uniform(-1.5, 1.5, (2 * POINTS_PER_TASK + 17, 3))
    whole = tree.evaluate(points, threads=2)
    np.testing.assert_array_equal(tree.evaluate(points, threads=1), whole)
    batches = np.concatenate([tree.evaluate(part) for part in np.array_split(points, 7)])
    np.testing.assert_array_equal(batches, whole)  # each point's walk is its own
    shuffled = np.random.default_rng(9).permutation(len(points))
    np.testing.assert_array_equal(tree.evaluate(points[shuffled]), whole[shuffled])


def test_degenerate_input_stays_finite():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2], [0, 1, 3], [0, 0, 0]])  # collinear, fine, a point
    points = np.array([[0, 0, 0], [3, 3, 0], [0.2, 0.2, 1.0], [-1, 0.5, -2]])  # a corner too
    winding = fast_winding_numbers(vertices, faces, points)
    assert np.all(np.isfinite(winding))
    np.testing.assert_allclose(winding, _exact(vertices, faces, points), atol=1e-12)
    assert fast_winding_numbers(vertices, faces[:0], points).tolist() == [0.0] * 4
    assert fast_winding_numbers(vertices, faces, np.zeros((0, 3))).shape == (0,)


@pytest.mark.parametrize(
    ("vertices", "faces", "points", "beta", "message"),
    [
        (np.zeros((3, 2)), np.array([[0, 1, 2]]), np.zeros((1, 3)), 2.0, "vertices must be"),
        (np.zeros((3, 3)), np.array([[0, 1, 3]]), np.zeros((1, 3)), 2.0, "faces must index"),
        (np.zeros((3, 3)), np.array([[0, 1, 2]]), np.zeros((1, 2)), 2.0, "points_mm must be"),
        (np.zeros((3, 3)), np.array([[0, 1, 2]]), np.zeros((1, 3)), -1.0, "beta must be"),
    ],
)
def test_bad_input_is_named(vertices, faces, points, beta, message):
    with pytest.raises(ValueError, match=message):
        fast_winding_numbers(vertices, faces, points, beta=beta)
