"""Self-intersection counting against hand-made triangle pairs."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from offset.intersections import (
    _candidate_pairs,
    _crossing,
    count_self_intersections,
    intersecting_pairs,
)


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


def _brute_overlaps(lo, hi):
    i, j = np.triu_indices(len(lo), k=1)
    meet = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
    return i[meet], j[meet]


@pytest.mark.parametrize("chunk", [1, 7, 200_000])
def test_candidate_pairs_are_exactly_the_overlapping_boxes(chunk):
    # Many tiny boxes crowded into one grid cell, mid-sized ones and a few long ones
    # spanning many cells, some sharing faces exactly (closed boxes touch): every
    # overlapping pair once, in (i, j) order, however the pairs are chunked.
    rng = np.random.default_rng(1)
    centre = np.concatenate([
        rng.uniform(0.0, 10.0, (300, 3)),
        rng.uniform(4.0, 4.2, (150, 3)),
        rng.uniform(0.0, 10.0, (10, 3)),
    ])
    half = np.concatenate([
        rng.uniform(0.05, 0.5, (300, 3)),
        rng.uniform(0.001, 0.01, (150, 3)),
        rng.uniform(2.0, 5.0, (10, 3)),
    ])
    lo, hi = centre - half, centre + half
    lo[5], hi[5] = hi[6].copy(), hi[6] + 1.0  # touch at a corner
    order = rng.permutation(len(lo))
    lo, hi = lo[order], hi[order]
    first, second = _candidate_pairs(lo, hi, chunk=chunk)
    ref_i, ref_j = _brute_overlaps(lo, hi)
    assert len(ref_i) > 1000
    np.testing.assert_array_equal(first, ref_i)
    np.testing.assert_array_equal(second, ref_j)


def test_intersecting_pairs_match_all_pairs_test():
    # A crumpled sphere crossing itself in many places: the grid broad phase with
    # chunking finds exactly the pairs an all-pairs run of the narrow phase finds.
    rng = np.random.default_rng(2)
    sphere = trimesh.creation.icosphere(2, 1.0)
    v = np.asarray(sphere.vertices) + rng.normal(0.0, 0.2, (len(sphere.vertices), 3))
    f = np.asarray(sphere.faces, dtype=np.int64)
    i, j = np.triu_indices(len(f), k=1)
    apart = ~(f[i][:, :, None] == f[j][:, None, :]).any(axis=(1, 2))
    i, j = i[apart], j[apart]
    eps = 1e-10 * float(np.ptp(v, axis=0).max())
    hit = _crossing(v[f[i]], v[f[j]], eps)
    expected = np.stack([i[hit], j[hit]], axis=1)
    assert len(expected) > 10
    for chunk in (3, 200_000):
        np.testing.assert_array_equal(intersecting_pairs(v, f, chunk=chunk), expected)
