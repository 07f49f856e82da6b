"""The guarded simplification locks the triangles where Manifold's edge collapse folds.

Manifold's simplification of the layer-field shell of spot at 30 mm (step 0.1 mm) folds a
few triangles over their neighbours around slivers, which MeshLab's self-intersection test
sees in the file; the guard keeps the unsimplified triangles there (an own ``face_id`` each)
and simplifies the rest, or a tidy pass removes the fold. Checked by MeshLab and trimesh,
not by the project's own test.
"""

from __future__ import annotations

import numpy as np
import trimesh
from meshlab_process import meshlab_crossing_faces, needs_meshlab
from scipy.spatial import cKDTree

from offset import simplify_passes
from offset.simplify import GuardLimits, simplify_shells
from offset.simplify_passes import manifold_simplify
from voxel.geometry._layer_field import field_surfaces
from voxel.geometry._nearest import SurfaceIndex

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
    monkeypatch.setattr(simplify_passes, "simplified", simplify_passes.manifold_simplify)
    spot = _spot(shared_mesh, 30.0)
    v0, f0 = np.asarray(spot.vertices), np.asarray(spot.faces, dtype=np.int64)
    depth = np.full((1, len(f0)), 0.5)
    ((v, f),) = field_surfaces(v0, f0, depth, 0.1, merge_planar=False).surfaces
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
    ((v, f),) = field_surfaces(v0, f0, depth, 0.1, merge_planar=False).surfaces
    assert meshlab_crossing_faces(*manifold_simplify(v, f, ONE_TRY.tolerance_mm)) > 0
    out = simplify_shells([(v, f)], SurfaceIndex.build(v0, f0), depth, limits=ONE_TRY)
    assert out.record["tolerance_mm"] == ONE_TRY.tolerance_mm
    assert out.record["lock_rounds"] == 0  # no lock was needed: the tidy pass removed it
    assert meshlab_crossing_faces(*out.meshes[0]) == 0
