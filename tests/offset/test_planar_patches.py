"""Planar patches triangulated again: the same surface, closed, with fewer triangles."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.field.layer_field import _unit_normals, field_surfaces
from shellvox.offset.field.planar_patches import merge_planar_patches
from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface


def _closed(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert (mesh.area_faces > 0).all()
    return mesh


def _same_surface(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> None:
    """Every sample of each surface lies on the other (within 1e-8 mm)."""
    for (v, f), (ov, of) in ((a, b), (b, a)):
        points, _ = trimesh.sample.sample_surface(
            trimesh.Trimesh(v, f, process=False), 20_000, seed=1
        )
        other = SurfaceIndex.build(ov, of)
        assert distance_to_surface(other, np.asarray(points)).max() <= 1e-8


@pytest.mark.parametrize("angles", [(0.0, 0.0, 0.0), (17.0, -33.0, 51.0)])
def test_a_box_inset_is_the_same_surface_in_far_fewer_triangles(angles):
    box = trimesh.creation.box((6.0, 4.0, 5.0))
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
    turn[:3, 3] = (0.1, 0.2, 0.3)
    box.apply_transform(turn)
    v0, f0 = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    depth = np.array([np.full(12, 0.5), np.full(12, 1.0)])
    merged = field_surfaces(v0, f0, depth, 0.1)
    marched = field_surfaces(v0, f0, depth, 0.1, merge_planar=False)  # creases put back
    as_marched = field_surfaces(v0, f0, depth, 0.1, merge_planar=False, sharpen=False)
    assert merged.marched_faces == [len(f) for _, f in as_marched.surfaces]
    for k in range(2):
        mesh = _closed(*merged.surfaces[k])
        raw = _closed(*marched.surfaces[k])
        assert len(mesh.faces) < len(raw.faces) / 5
        assert mesh.volume == pytest.approx(raw.volume, rel=1e-12)
        assert mesh.area == pytest.approx(raw.area, rel=1e-12)
        _same_surface(merged.surfaces[k], marched.surfaces[k])
        # Every vertex kept is one of the marched surface's (no new points).
        kept = {tuple(p) for p in marched.surfaces[k][0]}
        assert all(tuple(p) in kept for p in merged.surfaces[k][0])
    (v1, f1), (v2, f2) = merged.surfaces
    both = np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])
    assert len(intersecting_pairs(*both)) == 0


def _cube_grid(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A unit cube with n x n squares a side, merged; each vertex's side (-1 on edges)."""
    cube = trimesh.creation.box((1.0, 1.0, 1.0))
    for _ in range(int(np.log2(n))):
        cube = cube.subdivide()
    cube.merge_vertices()
    v, f = np.asarray(cube.vertices), np.asarray(cube.faces, dtype=np.int64)
    on = np.isclose(np.abs(v), 0.5)
    side = np.full(len(v), -1, dtype=np.int32)
    lone = on.sum(axis=1) == 1
    axis = np.argmax(on, axis=1)
    side[lone] = (2 * axis + (v[np.arange(len(v)), axis] > 0))[lone]
    return v, f, side


def _side_planes() -> tuple[np.ndarray, np.ndarray]:
    normals = np.zeros((6, 3))
    for s in range(6):
        normals[s, s // 2] = 1.0 if s % 2 else -1.0
    return normals, np.full(6, 0.5)


def test_patches_with_a_hole_and_touching_loops():
    v, f, side = _cube_grid(16)
    normals, levels = _side_planes()
    # A hole: one interior vertex of the +x side belongs to no patch.
    hole = np.flatnonzero((side == 1) & np.isclose(v[:, 1], 0.0) & np.isclose(v[:, 2], 0.0))
    side[hole] = -1
    out = merge_planar_patches(v, f, side, normals, levels)
    mesh = _closed(out.vertices, out.faces)
    assert out.faces_before == len(f)
    assert out.patches == 6
    assert mesh.volume == pytest.approx(1.0, rel=1e-12)
    assert mesh.area == pytest.approx(6.0, rel=1e-12)
    assert len(out.faces) < len(f) / 2
    # The hole's ring is kept: the unlabelled vertex and its neighbours are there.
    assert np.isclose(out.vertices, v[hole]).all(axis=1).any()
    _same_surface((out.vertices, out.faces), (v, f))


def test_a_patch_whose_boundary_touches_itself_keeps_its_triangles_at_that_vertex():
    v, f, side = _cube_grid(16)
    normals, levels = _side_planes()
    # Two vertices of the +z side whose 1-rings share one vertex and no edge: without them
    # (and their triangles) the side's patch has two holes that touch at that vertex.
    top = np.flatnonzero((side == 5) & (np.abs(v[:, :2]) < 0.3).all(axis=1))
    a = int(top[np.argmin(np.linalg.norm(v[top, :2], axis=1))])
    b = next(int(c) for c in top if _touch_at_a_vertex(f, a, int(c)))
    shared = (set(f[(f == a).any(axis=1)].ravel()) & set(f[(f == b).any(axis=1)].ravel())).pop()
    side[[a, b]] = -1
    out = merge_planar_patches(v, f, side, normals, levels)
    _closed(out.vertices, out.faces)
    assert out.patches == 6  # the +z side too, without its triangles at the touching vertex
    at_touch = f[(f == shared).any(axis=1)]
    kept = {tuple(sorted(map(tuple, v[t]))) for t in at_touch}
    now = {tuple(sorted(map(tuple, out.vertices[t]))) for t in out.faces}
    assert kept <= now
    on_top = (side[f] == 5).all(axis=1)
    assert len(out.faces) < len(f) - on_top.sum() / 2  # the +z side merged too
    _same_surface((out.vertices, out.faces), (v, f))


def _touch_at_a_vertex(faces: np.ndarray, a: int, b: int) -> bool:
    """Whether the triangles around a and those around b share one vertex and no edge."""
    around_a = faces[(faces == a).any(axis=1)]
    around_b = faces[(faces == b).any(axis=1)]
    shared = set(around_a.ravel()) & set(around_b.ravel())
    edges_a = {frozenset(e) for t in around_a for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    edges_b = {frozenset(e) for t in around_b for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    return len(shared) == 1 and not edges_a & edges_b


def test_vertices_off_the_plane_stay():
    v, f, side = _cube_grid(4)
    normals, levels = _side_planes()
    bumped = v.copy()
    top = np.flatnonzero((side == 5) & np.isclose(v[:, 0], 0.0) & np.isclose(v[:, 1], 0.0))
    bumped[top, 2] += 1e-4  # 0.1 um off the plane: not in the patch
    out = merge_planar_patches(bumped, f, side, normals, levels)
    _closed(out.vertices, out.faces)
    assert np.isclose(out.vertices, bumped[top]).all(axis=1).any()
    _same_surface((out.vertices, out.faces), (bumped, f))


def test_unit_normals_of_a_box_point_out():
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    np.testing.assert_allclose(
        _unit_normals(np.asarray(box.vertices), np.asarray(box.faces)), box.face_normals
    )
