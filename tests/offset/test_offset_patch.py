"""Local recomputation of a robust core around triangles deeper than asked
(shellvox.offset.reference.robust).

The defects are made by hand (a corner of the exact core pushed deeper, as a Boolean fold
or crack does); the truth is the analytic inner box, independent of the construction.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.csgraph
import trimesh

from shellvox.offset.reference import core_cut, robust
from shellvox.offset.reference.band import features, layer_pieces
from shellvox.offset.reference.guards import Surface, too_deep, too_deep_count
from shellvox.offset.reference.union import to_manifold

SIZE = 10.0
DEPTH = 0.5
INNER = SIZE / 2 - DEPTH  # the exact core is the box [-4.5, 4.5]^3


def _box(size: float) -> tuple[np.ndarray, np.ndarray]:
    box = trimesh.creation.box((size, size, size))
    return np.asarray(box.vertices, dtype=np.float64), np.asarray(box.faces, dtype=np.int64)


def _dent(vert: np.ndarray, amount: float) -> np.ndarray:
    """Push the core's (+x, +y, +z) corner down by `amount`: its top is cut deeper.

    Boolean output may hold several vertices within a micrometre of the corner (ends of
    sliver edges); all of them move.
    """
    vert = vert.copy()
    corner = np.linalg.norm(vert - INNER, axis=1) < 1e-2
    assert corner.any()
    vert[corner, 2] -= amount
    return vert


def _assert_exact_inner_box(vert: np.ndarray, tri: np.ndarray) -> None:
    mesh = trimesh.Trimesh(vert, tri, process=False)
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume == pytest.approx((2 * INNER) ** 3, rel=1e-9)
    np.testing.assert_allclose(mesh.bounds, [[-INNER] * 3, [INNER] * 3], atol=1e-9)


def test_too_deep_mask_marks_the_dented_triangles():
    v, f = _box(SIZE)
    core_v, core_f = _box(2 * INNER)
    dented = _dent(core_v, 0.2)
    surface = Surface(v, f)
    mask = too_deep(surface, np.full(len(f), DEPTH), dented, core_f)
    # Independent depth of each centroid: trimesh's closest points on the outer box.
    centroid = dented[core_f].mean(axis=1)
    dist = trimesh.proximity.closest_point(trimesh.Trimesh(v, f), centroid)[1]
    np.testing.assert_array_equal(mask, dist > DEPTH * (1 + 1e-3))
    assert mask.any()
    assert too_deep_count(surface, np.full(len(f), DEPTH), dented, core_f) == mask.sum()


def test_patch_restores_the_exact_core_around_a_dent():
    v, f = _box(SIZE)
    d = np.full(len(f), DEPTH)
    pieces = layer_pieces(features(v, f), d)
    core_v, core_f = _box(2 * INNER)
    dented = _dent(core_v, 0.2)
    surface = Surface(v, f)
    bad = too_deep(surface, d, dented, core_f)
    base = to_manifold(v, f).as_original()
    vert, tri = core_cut.patch_core(base, pieces, dented, core_f, bad, DEPTH, DEPTH, robust.LEAF)
    _assert_exact_inner_box(vert, tri)
    assert too_deep_count(surface, d, vert, tri) == 0


def test_robust_offset_repairs_a_dented_cut_without_warning(monkeypatch):
    """Every union order gives the same dent: only the local patch can repair it."""
    cut = robust.cut_core

    def dented_cut(*args, **kwargs):
        vert, tri = cut(*args, **kwargs)
        return _dent(vert, 0.2), tri

    monkeypatch.setattr(robust, "cut_core", dented_cut)
    v, f = _box(SIZE)
    # pyproject turns warnings into errors: a ShellDefectWarning fails the test.
    [(vert, tri)] = robust.robust_offset(v, f, np.full((1, len(f)), DEPTH))
    _assert_exact_inner_box(vert, tri)


def test_boxes_cluster_like_the_dense_overlap_graph():
    """Clusters of padded boxes equal the components of the all-pairs overlap test."""
    rng = np.random.default_rng(2)
    tris = rng.random((300, 1, 3)) * 60 + rng.random((300, 3, 3)) * rng.random((300, 1, 1)) * 4
    lo, hi = core_cut._boxes(tris, 0.5)
    t_lo, t_hi = tris.min(axis=1) - 0.5, tris.max(axis=1) + 0.5
    overlap = np.all((t_lo[:, None] <= t_hi[None]) & (t_hi[:, None] >= t_lo[None]), axis=2)
    n, label = scipy.sparse.csgraph.connected_components(
        scipy.sparse.csr_matrix(overlap), directed=False
    )
    assert len(lo) == n < len(tris)
    expect_lo = np.full((n, 3), np.inf)
    np.minimum.at(expect_lo, label, t_lo)
    # Same boxes, whatever the cluster numbering.
    np.testing.assert_array_equal(lo[np.lexsort(lo.T)], expect_lo[np.lexsort(expect_lo.T)])
    assert np.all(hi > lo)


def test_robust_offset_repairs_a_crossing_cut_without_warning(monkeypatch):
    """A small closed component crossing the core's top face, in every union order."""
    cut = robust.cut_core
    stray = trimesh.creation.box((0.2, 0.2, 0.2))
    stray.apply_translation([1.0, -2.0, INNER])  # straddles the top face z = INNER

    def crossing_cut(*args, **kwargs):
        vert, tri = cut(*args, **kwargs)
        return (
            np.concatenate([vert, stray.vertices]),
            np.concatenate([tri, np.asarray(stray.faces) + len(vert)]),
        )

    monkeypatch.setattr(robust, "cut_core", crossing_cut)
    v, f = _box(SIZE)
    # The defect is seen (and not simplified away) before the repair.
    dirty_v, dirty_f = crossing_cut(
        to_manifold(v, f).as_original(),
        layer_pieces(features(v, f), np.full(len(f), DEPTH)),
        DEPTH,
        DEPTH,
        robust.LEAF,
    )
    assert core_cut.uncross(dirty_v, dirty_f, DEPTH)[3] > 0
    # pyproject turns warnings into errors: a ShellDefectWarning fails the test.
    [(vert, tri)] = robust.robust_offset(v, f, np.full((1, len(f)), DEPTH))
    _assert_exact_inner_box(vert, tri)
