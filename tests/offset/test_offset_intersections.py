"""Self-intersection counting against hand-made triangle pairs."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.offset.crossing import intersections
from shellvox.offset.crossing.intersections import (
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
    centre = np.concatenate(
        [
            rng.uniform(0.0, 10.0, (300, 3)),
            rng.uniform(4.0, 4.2, (150, 3)),
            rng.uniform(0.0, 10.0, (10, 3)),
        ]
    )
    half = np.concatenate(
        [
            rng.uniform(0.05, 0.5, (300, 3)),
            rng.uniform(0.001, 0.01, (150, 3)),
            rng.uniform(2.0, 5.0, (10, 3)),
        ]
    )
    lo, hi = centre - half, centre + half
    lo[5], hi[5] = hi[6].copy(), hi[6] + 1.0  # touch at a corner
    order = rng.permutation(len(lo))
    lo, hi = lo[order], hi[order]
    first, second = _candidate_pairs(lo, hi, chunk=chunk)
    ref_i, ref_j = _brute_overlaps(lo, hi)
    assert len(ref_i) > 1000
    np.testing.assert_array_equal(first, ref_i)
    np.testing.assert_array_equal(second, ref_j)


@pytest.mark.parametrize("threads", [1, 2])
def test_intersecting_pairs_match_all_pairs_test(threads, monkeypatch):
    # A crumpled sphere crossing itself in many places: the grid broad phase with
    # chunking finds exactly the pairs an all-pairs run of the narrow phase finds, with
    # the spans walked in one thread or side by side.
    monkeypatch.setattr(intersections, "_threads", lambda: threads)
    rng = np.random.default_rng(2)
    sphere = trimesh.creation.icosphere(2, 1.0)
    v = np.asarray(sphere.vertices) + rng.normal(0.0, 0.2, (len(sphere.vertices), 3))
    f = np.asarray(sphere.faces, dtype=np.int64)
    i, j = np.triu_indices(len(f), k=1)
    apart = (f[i][:, :, None] == f[j][:, None, :]).sum(axis=(1, 2)) < 2  # no common edge
    i, j = i[apart], j[apart]
    eps = 1e-10 * float(np.ptp(v, axis=0).max())
    hit = _crossing(v[f[i]], v[f[j]], eps)
    expected = np.stack([i[hit], j[hit]], axis=1)
    assert len(expected) > 10
    for chunk in (3, 200_000):
        np.testing.assert_array_equal(intersecting_pairs(v, f, chunk=chunk), expected)


def _fan_and_dust(rng):
    """A fan of 120 long slivers (10 mm) around a centre among 1500 triangles of ~1 um.

    Mixed sizes as in CAD meshes: the median box is a micrometre, the slivers span ten
    thousand such cells per axis.
    """
    angle = np.sort(rng.uniform(0.0, 2.0 * np.pi, 120))
    rim = 10.0 * np.stack([np.cos(angle), np.sin(angle), rng.uniform(-0.1, 0.1, 120)], axis=1)
    fan = np.stack([np.zeros((120, 3)), rim, np.roll(rim, -1, axis=0)], axis=1)
    centre = np.concatenate([rng.uniform(-10.0, 10.0, (1000, 3)), rng.normal(0.0, 1e-3, (500, 3))])
    centre[:1000, 2] *= 0.01
    dust = centre[:, None, :] + rng.normal(0.0, 1e-3, (1500, 3, 3))
    return np.concatenate([fan, dust])


@pytest.mark.parametrize("shift", [0.0, 1e6])
def test_candidate_pairs_of_long_slivers_among_dust_are_exact(shift):
    tri = _fan_and_dust(np.random.default_rng(3)) + shift
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    ref_i, ref_j = _brute_overlaps(lo, hi)
    assert len(ref_i) > 5000
    for chunk in (50, 200_000):
        first, second = _candidate_pairs(lo, hi, chunk=chunk)
        np.testing.assert_array_equal(first, ref_i)
        np.testing.assert_array_equal(second, ref_j)


@pytest.mark.parametrize("share", [0.0, 0.01, 0.3, 1.0])
def test_candidate_pairs_with_an_active_box_are_exact(share):
    # Long slivers among dust (a pair of two slivers, of a sliver and a speck, of two
    # specks): with some boxes active, exactly the overlapping pairs that hold one, as
    # all pairs tested by brute force give them; slivers active or not.
    rng = np.random.default_rng(7)
    tri = _fan_and_dust(rng)
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    ref_i, ref_j = _brute_overlaps(lo, hi)
    for active in (rng.random(len(tri)) < share, np.r_[np.ones(120, bool), np.zeros(1500, bool)]):
        keep = active[ref_i] | active[ref_j]
        for chunk in (50, 200_000):
            first, second = _candidate_pairs(lo, hi, chunk=chunk, active=active)
            np.testing.assert_array_equal(first, ref_i[keep])
            np.testing.assert_array_equal(second, ref_j[keep])
    assert keep.sum() > 1000


def test_candidate_pairs_of_identical_points():
    lo = np.ones((5, 3))
    first, second = _candidate_pairs(lo, lo.copy())
    ref_i, ref_j = np.triu_indices(5, k=1)
    np.testing.assert_array_equal(first, ref_i)
    np.testing.assert_array_equal(second, ref_j)


def _brute_crossing(v, f):
    """The narrow phase on every pair of overlapping boxes, found by testing all pairs."""
    eps = 1e-10 * float(np.ptp(v, axis=0).max())
    tri = v[f]
    i, j = _brute_overlaps(tri.min(axis=1) - eps, tri.max(axis=1) + eps)
    apart = (f[i][:, :, None] == f[j][:, None, :]).sum(axis=(1, 2)) < 2  # no common edge
    i, j = i[apart], j[apart]
    hit = _crossing(tri[i], tri[j], eps)
    return np.stack([i[hit], j[hit]], axis=1)


def test_intersecting_pairs_of_a_fan_crossing_dust_match_brute_force():
    tri = _fan_and_dust(np.random.default_rng(4))
    v = tri.reshape(-1, 3)
    f = np.arange(len(v), dtype=np.int64).reshape(-1, 3)
    expected = _brute_crossing(v, f)
    assert len(expected) > 10
    np.testing.assert_array_equal(intersecting_pairs(v, f, chunk=1000), expected)


def test_robust_offset_of_a_cylinder_checks_its_shell_exactly():
    # The cylinder's caps are fans of long triangles; its robust shell mixes them with
    # micrometre slivers (a median box of 3 um beside 9 mm ones), where a single grid of
    # the median cell needed about 4e9 cells (a 30 GiB allocation).
    from shellvox.offset import offset_shells

    cylinder = trimesh.creation.cylinder(radius=5.0, height=10.0, sections=64)
    (shell,) = offset_shells(cylinder.vertices, cylinder.faces, [0.5], method="robust")
    v, f = shell.vertices, shell.faces
    tri = v[f]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    ref_i, ref_j = _brute_overlaps(lo, hi)
    first, second = _candidate_pairs(lo, hi, chunk=5000)
    np.testing.assert_array_equal(first, ref_i)
    np.testing.assert_array_equal(second, ref_j)
    assert len(intersecting_pairs(v, f)) == len(_brute_crossing(v, f)) == 0


@pytest.mark.parametrize(
    ("apex", "expected"),
    [
        ([0.5, 0.5, 1.0], 0),  # a fan around the shared vertex: apart beyond it
        ([0.5, -0.5, 0.0], 0),  # meets z = 0 beside triangle 0
        ([1.0, 1.0, -1.0], 1),  # passes through the other triangle beyond the vertex
    ],
)
def test_pairs_sharing_one_vertex(apex, expected):
    # Triangle 0 in z = 0; triangle 1 shares its vertex 0 (the origin) and runs from
    # there through (1, 1, 0.5)...: its segment in z = 0 starts at the origin and, for
    # the last apex, crosses the interior of triangle 0.
    v = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [1, 1, 1], apex], dtype=np.float64)
    f = np.array([[0, 1, 2], [0, 3, 4]])
    assert count_self_intersections(v, f) == expected


def _numpy_crossing(a, b, eps):
    """Moeller's interval test as whole-array numpy on (P, 3, 3) pairs (a reference)."""
    na = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    nb = np.cross(b[:, 1] - b[:, 0], b[:, 2] - b[:, 0])
    na /= np.maximum(np.linalg.norm(na, axis=1, keepdims=True), 1e-300)
    nb /= np.maximum(np.linalg.norm(nb, axis=1, keepdims=True), 1e-300)
    db = np.einsum("pij,pj->pi", b - a[:, :1], na)
    da = np.einsum("pij,pj->pi", a - b[:, :1], nb)
    db = np.where(np.abs(db) <= eps, 0.0, db)
    da = np.where(np.abs(da) <= eps, 0.0, da)
    line = np.cross(na, nb)

    def interval(t, d):
        p = np.einsum("pij,pj->pi", t, line)
        di, dj = d, np.roll(d, -1, axis=1)
        pi, pj = p, np.roll(p, -1, axis=1)
        cross = di * dj < 0
        s = pi + (pj - pi) * np.where(cross, di / np.where(cross, di - dj, 1.0), 0.0)
        cand = np.concatenate([np.where(cross, s, np.nan), np.where(d == 0, p, np.nan)], axis=1)
        return np.nanmin(np.where(np.isnan(cand), np.inf, cand), axis=1), np.nanmax(
            np.where(np.isnan(cand), -np.inf, cand), axis=1
        )

    lo_a, hi_a = interval(a, da)
    lo_b, hi_b = interval(b, db)
    separated = np.any(
        [np.all(db > 0, 1), np.all(db < 0, 1), np.all(da > 0, 1), np.all(da < 0, 1)], axis=0
    )
    coplanar = np.all(db == 0, axis=1) | np.all(da == 0, axis=1)
    straddle = (np.any(db > 0, 1) & np.any(db < 0, 1)) | (np.any(da > 0, 1) & np.any(da < 0, 1))
    overlap = np.minimum(hi_a, hi_b) - np.maximum(lo_a, lo_b)
    return ~separated & ~coplanar & straddle & (overlap > eps)


def test_compiled_narrow_phase_matches_numpy_reference():
    # Random pairs, pairs sharing a corner, touching at a corner, coplanar and nearly
    # coplanar (within the tolerance): the compiled test decides every one as the
    # whole-array numpy formulation of the same interval test does.
    rng = np.random.default_rng(5)
    n = 20_000
    a = rng.uniform(-1.0, 1.0, (n, 3, 3))
    b = rng.uniform(-1.0, 1.0, (n, 3, 3))
    b[: n // 4, 0] = a[: n // 4, 0]  # a shared corner
    b[n // 4 : n // 2, 1] = a[n // 4 : n // 2, 2]  # touching at a corner
    flat = slice(n // 2, 3 * n // 4)
    a[flat, :, 2] = 0.0
    b[flat, :, 2] = rng.choice([0.0, 1e-12, 1e-3], size=(n // 4, 3))  # (nearly) coplanar
    eps = 1e-10
    expected = _numpy_crossing(a, b, eps)
    assert 100 < expected.sum() < n - 100
    np.testing.assert_array_equal(_crossing(a, b, eps), expected)


def test_intersecting_pairs_only_tests_pairs_with_a_chosen_face():
    # The crumpled sphere: with `only`, exactly the full result's pairs that have at
    # least one chosen face.
    rng = np.random.default_rng(2)
    sphere = trimesh.creation.icosphere(2, 1.0)
    v = np.asarray(sphere.vertices) + rng.normal(0.0, 0.2, (len(sphere.vertices), 3))
    f = np.asarray(sphere.faces, dtype=np.int64)
    full = intersecting_pairs(v, f)
    only = rng.random(len(f)) < 0.2
    expected = full[only[full[:, 0]] | only[full[:, 1]]]
    assert 0 < len(expected) < len(full)
    np.testing.assert_array_equal(intersecting_pairs(v, f, only=only), expected)
    assert len(intersecting_pairs(v, f, only=np.zeros(len(f), dtype=bool))) == 0
