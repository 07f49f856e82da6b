"""The guarded simplification locks the triangles where Manifold's edge collapse folds.

Manifold's simplification of the layer-field shell of spot at 30 mm (step 0.1 mm) folds a
few triangles over their neighbours around slivers, which MeshLab's self-intersection test
sees in the file; the guard keeps the unsimplified triangles there (an own ``face_id`` each)
and simplifies the rest, or a tidy pass removes the fold. Checked by MeshLab and trimesh,
not by the project's own test.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from meshlab_process import needs_meshlab
from scipy.spatial import cKDTree

from shellvox.offset.field import simplify_passes
from shellvox.offset.field.layer_field import field_surfaces
from shellvox.offset.field.simplify import GuardLimits, simplify_shells
from shellvox.offset.field.simplify_passes import manifold_simplify
from shellvox.testing import HAVE_PYMESHLAB, meshlab_checks, meshlab_crossing_faces
from shellvox.voxel.geometry._nearest import SurfaceIndex

#: One try at Manifold's first tolerance (the error bounds are tested elsewhere).
ONE_TRY = GuardLimits(max_error_mm=1.0, p99_error_share=1.0, tries=1)


def _spot(shared_mesh, size_mm: float) -> trimesh.Trimesh:
    raw = trimesh.load(shared_mesh("spot/spot_triangulated.obj"), force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.apply_scale(size_mm / mesh.extents.max())
    return mesh


def _unchanged(vertices: np.ndarray, faces: np.ndarray, before: tuple) -> int:
    """Count the triangles of a mesh that are triangles of `before`, corners within 1e-6 mm."""

    def corners(v: np.ndarray, f: np.ndarray) -> np.ndarray:
        tri = v[f]
        order = np.lexsort(tri.transpose(2, 0, 1)[::-1], axis=-1)
        return np.take_along_axis(tri, order[:, :, None], axis=1).reshape(-1, 9)

    distance, _ = cKDTree(corners(*before)).query(corners(vertices, faces))
    return int((distance < 1e-6).sum())


@needs_meshlab
def test_a_folded_simplification_is_simplified_again_with_the_fold_locked(shared_mesh, monkeypatch):
    # Without the tidy pass (which removes this fold too), so that the lock is what does it.
    def one_pass(vertices, faces, tolerance_mm, *, locked=None):
        return simplify_passes._manifold_simplify(vertices, faces, tolerance_mm, locked)

    monkeypatch.setattr(simplify_passes, "simplified", one_pass)
    spot = _spot(shared_mesh, 30.0)
    v0, f0 = np.asarray(spot.vertices), np.asarray(spot.faces, dtype=np.int64)
    depth = np.full((1, len(f0)), 0.5)
    ((v, f),) = field_surfaces(v0, f0, depth, 0.1, merge_planar=False, sharpen=False).surfaces
    folded = manifold_simplify(v, f, ONE_TRY.tolerance_mm)
    assert meshlab_crossing_faces(*folded) > 0  # the case under test: Manifold folds here

    out = simplify_shells([(v, f)], SurfaceIndex.build(v0, f0), depth, limits=ONE_TRY)
    record = out.record
    assert record["tolerance_mm"] == ONE_TRY.tolerance_mm  # accepted at the first try
    assert record["lock_rounds"] >= 1 and record["locked_faces"][0] > 0
    ((sv, sf),) = out.meshes
    assert meshlab_crossing_faces(sv, sf) == 0
    shell = trimesh.Trimesh(sv, sf, process=False)
    assert shell.is_watertight and shell.is_winding_consistent
    assert len(sf) < len(f) / 4  # still simplified away from the locks
    # The accepted shell is the jittered one (by at most 1e-8 of the size) unless the jitter
    # made a crossing; a locked triangle comes out as it went in, up to that move.
    assert _unchanged(sv, sf, (v, f)) >= record["locked_faces"][0]


@needs_meshlab
def test_the_tidy_pass_removes_the_fold(shared_mesh):
    spot = _spot(shared_mesh, 30.0)
    v0, f0 = np.asarray(spot.vertices), np.asarray(spot.faces, dtype=np.int64)
    depth = np.full((1, len(f0)), 0.5)
    ((v, f),) = field_surfaces(v0, f0, depth, 0.1, merge_planar=False, sharpen=False).surfaces
    assert meshlab_crossing_faces(*manifold_simplify(v, f, ONE_TRY.tolerance_mm)) > 0
    out = simplify_shells([(v, f)], SurfaceIndex.build(v0, f0), depth, limits=ONE_TRY)
    assert out.record["tolerance_mm"] == ONE_TRY.tolerance_mm
    assert out.record["lock_rounds"] == 0  # no lock was needed: the tidy pass removed it
    assert meshlab_crossing_faces(*out.meshes[0]) == 0


def test_a_vertex_split_in_two_at_one_place_is_a_pinch():
    # Two tetrahedra touching at a corner, each with its own copy of it (what Manifold
    # makes of a collapse that pinches the surface): the six faces there are pinched; the
    # same position in two shells is no pinch.
    tet = trimesh.creation.box((1.0, 1.0, 1.0))
    a = np.asarray(tet.vertices)
    corner = a[np.argmax(a.sum(axis=1))]
    b = 2.0 * corner - a  # mirrored through that corner: one vertex lands on it
    both = (np.concatenate([a, b]), np.concatenate([tet.faces, tet.faces + len(a)]))
    pinched = simplify_passes.pinched_faces([both])
    touching = np.flatnonzero(np.all(both[0][both[1]] == corner, axis=2).any(axis=1))
    np.testing.assert_array_equal(pinched, touching)
    assert len(touching) >= 6
    assert len(simplify_passes.pinched_faces([(a, tet.faces), (b, tet.faces)])) == 0


def _field_shells(relative, size_mm):
    """The default method's shells (0.5 and 1.0 mm) of a shared mesh, largest side `size_mm`."""
    from conftest import shared_path

    from shellvox.offset import method_shells

    raw = trimesh.load(shared_path(relative), force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    mesh.apply_scale(size_mm / mesh.extents.max())
    return method_shells(mesh.vertices, mesh.faces, [0.5, 1.0])


@pytest.mark.slow
def test_field_shells_of_the_bunny_are_2_manifold_as_meshlab_reads_them(tmp_path):
    # The bunny at 50 mm: Manifold's collapse pinched shell 2 at one vertex (split in two
    # at one place, a non-manifold vertex once welded); the guard locks the triangles there.
    from shellvox.output import save_shells

    made = _field_shells("bunny/bunny.obj", 50.0)
    assert made.crossing_free and made.record["simplify"]["tolerance_mm"] > 0
    for written in save_shells(tmp_path, made.shells, crossing_free=made.crossing_free):
        assert written.checks["coincident_vertices"] == 0
        assert written.checks["closed"] and written.checks["self_intersections"] == 0
        _assert_no_needle(written)
        if HAVE_PYMESHLAB:
            checks = meshlab_checks(written.path)
            assert checks["two_manifold"] and checks["non_manifold_vertices"] == 0
            assert checks["self_intersecting_faces"] == 0


def _assert_no_needle(written):
    """The file's smallest angle, read by trimesh, is the one its checks state, and above
    0.01 degrees (the marched and simplified shells of the bunny and spot had angles under
    1e-4 degrees before the sliver pass)."""
    shell = trimesh.load(written.path, process=False, force="mesh")
    tri = np.asarray(shell.triangles)
    a, b = tri[:, [1, 2, 0]] - tri, tri[:, [2, 0, 1]] - tri
    sine = np.linalg.norm(np.cross(a, b), axis=2)  # arctan2: exact for tiny angles
    smallest = float(np.degrees(np.arctan2(sine, np.einsum("tij,tij->ti", a, b)).min()))
    print(f"{written.path.name}: smallest triangle angle {smallest:.3g} degrees")
    assert written.checks["min_angle_deg"] == pytest.approx(smallest, rel=1e-6)
    assert smallest > 0.01


def test_the_jitter_is_put_back_around_crossings_until_none_is_left(monkeypatch):
    # A crossing test that sees faces 0 and 1 cross while all is jittered, then faces 1
    # and 2 once the vertices of 0 and 1 are back (a put-back vertex against a moved
    # neighbour, as on the faceted spot at 100 mm), then none: the shells keep the jitter
    # everywhere else instead of falling back to the unjittered shells (whose exactly
    # coplanar flat parts MeshLab reads as crossings).
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    plain = [(np.asarray(box.vertices, dtype=np.float64), np.asarray(box.faces, dtype=np.int64))]
    v0, f0 = plain[0]

    def fake_crossings(meshes, only=None):
        back = np.all(meshes[0][0] == v0, axis=1)
        owner = np.zeros(len(f0), dtype=np.int64)
        pairs = np.zeros((0, 2), dtype=np.int64)
        if not back[f0[:2]].all():
            pairs = np.array([[0, 1]])
        elif not back[f0[2]].all():
            pairs = np.array([[1, 2]])
        if only is not None:
            pairs = pairs[only[pairs].any(axis=1)]
        return pairs, owner

    monkeypatch.setattr(simplify_passes, "crossings", fake_crossings)
    (shell,), pairs, _ = simplify_passes._jittered(plain)
    assert len(pairs) == 0
    back = np.all(shell[0] == v0, axis=1)
    np.testing.assert_array_equal(np.flatnonzero(back), np.unique(f0[:3]))
    assert np.abs(shell[0] - v0).max() <= simplify_passes.JITTER_FRACTION * 10.0


def test_crossings_of_the_simplification_itself_stop_the_put_back_at_once(monkeypatch):
    # Two boxes through each other, as one shell: they cross jittered or not. One round
    # puts the crossing triangles back; they still cross, all in place, so the shells are
    # returned with exactly the crossings a full test of them finds, after two tests.
    one = trimesh.creation.box((10.0, 10.0, 10.0))
    two = trimesh.creation.box((10.0, 10.0, 10.0))
    two.apply_translation((4.0, 3.0, 2.0))
    both = trimesh.util.concatenate([one, two])
    plain = [(np.asarray(both.vertices, np.float64), np.asarray(both.faces, np.int64))]
    calls = []
    real = simplify_passes.crossings

    def counted(meshes, only=None):
        calls.append(only is None)
        return real(meshes, only=only)

    monkeypatch.setattr(simplify_passes, "crossings", counted)
    shells, pairs, _ = simplify_passes._jittered(plain)
    assert calls == [True, False]
    full, _ = real(shells)
    assert len(full) > 0
    np.testing.assert_array_equal(pairs, full)
    crossing = np.unique(plain[0][1][np.unique(pairs)])
    np.testing.assert_array_equal(shells[0][0][crossing], plain[0][0][crossing])


@pytest.mark.slow
@needs_meshlab
def test_field_shell_files_of_spot_at_100_mm_are_clean_as_meshlab_reads_them(tmp_path):
    # The faceted spot at 100 mm, default method, both shells as written: MeshLab's
    # self-intersection selection selects nothing, and no triangle is degenerate.
    from shellvox.output import save_shells

    made = _field_shells("spot/spot_triangulated.obj", 100.0)
    assert made.crossing_free
    for written in save_shells(tmp_path, made.shells, crossing_free=made.crossing_free):
        assert written.checks["closed"] and written.checks["self_intersections"] == 0
        checks = meshlab_checks(written.path)
        assert checks["self_intersecting_faces"] == 0
        assert checks["two_manifold"]
        _assert_no_needle(written)
