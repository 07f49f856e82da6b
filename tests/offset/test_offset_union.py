"""Union of overlapping pieces (shellvox.offset.reference.union) against analytic volumes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.offset.reference.union import morton_order, union_pieces


def _cubes(corners: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    cube = trimesh.creation.box((size, size, size))
    pts = np.asarray(cube.vertices)[None] + corners[:, None, :] + size / 2
    return pts, np.asarray(cube.faces, dtype=np.int64)


@pytest.mark.parametrize("leaf", [1, 3, 16])
def test_union_of_a_row_of_overlapping_cubes_has_the_volume_of_their_hull(leaf):
    # Unit cubes shifted by 0.5 along x overlap their neighbours by half: the union is
    # a box of length 0.5 * (n + 1).
    n = 37
    rng = np.random.default_rng(1)
    corners = np.zeros((n, 3))
    corners[:, 0] = 0.5 * rng.permutation(n)
    union = union_pieces([_cubes(corners, 1.0)], leaf=leaf)
    assert union.volume() == pytest.approx(0.5 * (n + 1), rel=1e-12)
    assert union.genus() == 0


def test_groups_of_different_topology_are_united():
    # A grid of disjoint unit cubes plus octahedra centred on half of them (inside).
    corners = np.stack(np.meshgrid(*[np.arange(4) * 2.0] * 3), axis=-1).reshape(-1, 3)
    octa = trimesh.creation.icosphere(subdivisions=0)  # 12 points, inside radius 1
    ball_pts = np.asarray(octa.vertices)[None] * 0.4 + corners[::2, None, :] + 0.5
    union = union_pieces([_cubes(corners, 1.0), (ball_pts, np.asarray(octa.faces, dtype=np.int64))])
    assert union.volume() == pytest.approx(len(corners), rel=1e-12)
    assert len(union.decompose()) == len(corners)


def test_morton_order_is_a_permutation_that_keeps_neighbours_close():
    rng = np.random.default_rng(0)
    points = rng.random((4096, 3))
    order = morton_order(points)
    np.testing.assert_array_equal(np.sort(order), np.arange(len(points)))
    step = np.linalg.norm(np.diff(points[order], axis=0), axis=1)
    random_step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert np.median(step) < 0.25 * np.median(random_step)


def test_no_pieces_give_an_empty_solid():
    assert union_pieces([(np.zeros((0, 8, 3)), np.zeros((12, 3), dtype=np.int64))]).is_empty()
