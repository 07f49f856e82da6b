"""Self-intersection counting against hand-made triangle pairs."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from offset.intersections import count_self_intersections, intersecting_pairs


def _pair(b_vertices):
    a = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]
    return np.array(a + b_vertices, dtype=np.float64), np.array([[0, 1, 2], [3, 4, 5]])


@pytest.mark.parametrize(
    ("b", "expected"),
    [
        ([[0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [1.5, -0.5, 0.0]], 1),  # pierces
        ([[0.5, 0.5, 0.5], [0.5, 0.5, 1.0], [1.5, -0.5, 0.5]], 0),  # above
        ([[3.0, 3.0, -1.0], [3.0, 3.0, 1.0], [4.0, 3.0, 0.0]], 0),  # beside the plane hit
        ([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, -1.0, 1.0]], 0),  # touches along an edge
        ([[0.2, 0.2, 0.0], [1.0, 0.2, 0.0], [0.2, 1.0, 0.0]], 0),  # coplanar overlap: ignored
    ],
)
def test_pair_cases(b, expected):
    v, f = _pair(b)
    assert count_self_intersections(v, f) == expected


def test_two_overlapping_spheres_cross_only_each_other():
    a = trimesh.creation.icosphere(2, 1.0)
    b = trimesh.creation.icosphere(2, 1.0).apply_translation([1.0, 0.0, 0.0])
    assert count_self_intersections(np.asarray(a.vertices), np.asarray(a.faces)) == 0
    both = trimesh.util.concatenate([a, b])
    pairs = intersecting_pairs(np.asarray(both.vertices), np.asarray(both.faces, np.int64))
    assert len(pairs) > 0
    n = len(a.faces)
    assert np.all((pairs[:, 0] < n) & (pairs[:, 1] >= n))
