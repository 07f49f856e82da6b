"""The solid of a soup on a voxel grid against libigl's winding numbers at every voxel."""

from __future__ import annotations

import igl
import numpy as np
import pytest
import trimesh
from conftest import shared_path

from shellvox.voxel.geometry import inside_slab
from shellvox.voxel.geometry._solid import boundary_edges, solid_slab, soup_solid
from shellvox.voxel.grid import GridSpec


def _grid(vertices: np.ndarray, voxel_mm: tuple[float, float, float]) -> GridSpec:
    voxel = np.asarray(voxel_mm)
    low = vertices.min(axis=0) - 2 * voxel
    shape = np.ceil((np.ptp(vertices, axis=0) + 4 * voxel) / voxel).astype(int)
    return GridSpec(tuple(low), tuple(voxel), tuple(int(n) for n in shape[::-1]))


def _libigl_inside(vertices, faces, grid):
    index = np.stack(np.meshgrid(*map(np.arange, grid.shape_zyx), indexing="ij"), -1)
    points = grid.index_to_world(index.reshape(-1, 3))
    winding = igl.fast_winding_number(vertices, faces, points)
    squared, _, _ = igl.point_mesh_squared_distance(points, vertices, faces)
    return (winding >= 0.5).reshape(grid.shape_zyx), np.sqrt(squared).reshape(grid.shape_zyx)


def _teapot() -> tuple[np.ndarray, np.ndarray]:
    mesh = trimesh.load(shared_path("teapot/teapot.obj"), process=False)
    mesh.merge_vertices()
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    return vertices * (40.0 / np.ptp(vertices, axis=0).max()), np.asarray(mesh.faces, np.int64)


def test_the_open_teapot_agrees_with_libigl_away_from_its_surface():
    vertices, faces = _teapot()
    assert len(boundary_edges(faces)) > 0  # open: the test is about holes
    grid = _grid(vertices, (0.5, 0.6, 0.4))
    solid = soup_solid(vertices, faces)
    ours = solid_slab(solid, grid, 0, grid.shape_zyx[0])
    truth, distance = _libigl_inside(vertices, faces, grid)
    far = distance > 2 * np.linalg.norm(grid.voxel_mm)
    assert truth[far].any() and (~truth[far]).any()
    assert (ours.inside[far] == truth[far]).mean() >= 0.999
    # only a share of the voxels was evaluated one by one
    assert ours.n_exact < 0.5 * truth.size


def test_slabs_give_the_whole_grids_solid():
    vertices, faces = _teapot()
    grid = _grid(vertices, (0.8, 0.9, 0.7))
    solid = soup_solid(vertices, faces)
    whole = solid_slab(solid, grid, 0, grid.shape_zyx[0]).inside
    cut = grid.shape_zyx[0] // 3
    parts = [solid_slab(solid, grid, a, b).inside for a, b in ((0, cut), (cut, grid.shape_zyx[0]))]
    truth, distance = _libigl_inside(vertices, faces, grid)
    far = distance > 2 * np.linalg.norm(grid.voxel_mm)
    for inside in (whole, np.concatenate(parts)):
        assert (inside[far] == truth[far]).mean() >= 0.999


def test_a_closed_mesh_is_its_exact_inside():
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=5.0)
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64)
    assert len(boundary_edges(faces)) == 0
    grid = _grid(vertices, (0.3, 0.35, 0.25))
    ours = solid_slab(soup_solid(vertices, faces), grid, 0, grid.shape_zyx[0])
    exact, _ = inside_slab(vertices, faces, grid, 0, grid.shape_zyx[0])
    np.testing.assert_array_equal(ours.inside, exact)


def test_overlapping_boxes_and_a_box_with_a_hole():
    a = trimesh.creation.box(extents=(10, 6, 6))
    b = trimesh.creation.box(extents=(6, 10, 6))
    b.apply_translation((3, 2, 1))
    holed = trimesh.creation.box(extents=(8, 8, 8))
    holed.apply_translation((0, 0, 12))
    top = np.flatnonzero(holed.face_normals[:, 2] > 0.9)
    holed.update_faces(np.setdiff1d(np.arange(len(holed.faces)), top))  # an open top
    soup = trimesh.util.concatenate([a, b, holed])
    vertices, faces = np.asarray(soup.vertices), np.asarray(soup.faces, np.int64)
    grid = _grid(vertices, (0.4, 0.45, 0.35))
    ours = solid_slab(soup_solid(vertices, faces), grid, 0, grid.shape_zyx[0])
    truth, distance = _libigl_inside(vertices, faces, grid)
    far = distance > 2 * np.linalg.norm(grid.voxel_mm)
    assert (ours.inside[far] == truth[far]).mean() >= 0.999
    # the overlap is inside once (a union), the open box's lower half is solid
    centre = np.rint(grid.world_to_index([[3.0, 0.0, 0.0], [0.0, 0.0, 10.0]])).astype(int)
    assert ours.inside[tuple(centre.T)].all()


def test_a_rims_shadow_between_lattice_rows_is_not_missed():
    # A ball with a hole facing -x: the rows through the hole cross one face fewer than
    # their neighbours, from the rim on. Near the top and bottom of the rim seen along x
    # such rows pass between the lattice's rows (10 voxels apart here), which all miss it.
    ball = trimesh.creation.icosphere(subdivisions=4, radius=5.0)
    faces = np.asarray(ball.faces, np.int64)[ball.face_normals[:, 0] > -0.7]
    vertices = np.asarray(ball.vertices)
    grid = _grid(vertices, (0.1, 0.11, 0.09))
    solid = soup_solid(vertices, faces, lattice_mm=1.0)
    ours = solid_slab(solid, grid, 0, grid.shape_zyx[0], lattice_mm=1.0)
    index = np.stack(np.meshgrid(*map(np.arange, grid.shape_zyx), indexing="ij"), -1)
    points = grid.index_to_world(index.reshape(-1, 3))
    winding = np.asarray(igl.fast_winding_number(vertices, faces, points))
    squared, _, _ = igl.point_mesh_squared_distance(points, vertices, faces)
    decided = (np.sqrt(squared) > 2 * np.linalg.norm(grid.voxel_mm)) & (
        np.abs(winding - 0.5) > 0.02  # libigl's own error aside
    )
    truth = (winding >= 0.5).reshape(grid.shape_zyx)
    wrong = decided.reshape(grid.shape_zyx) & (ours.inside != truth)
    assert not wrong.any(), f"{wrong.sum()} voxels in rows (z, y) {np.argwhere(wrong)[:3, :2]}"
    assert ours.n_exact < 0.8 * truth.size


def test_boundary_edges_of_non_manifold_and_misoriented_edges():
    # three faces on one edge (0, 1): it does not cancel
    faces = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert [0, 1] in boundary_edges(faces).tolist()
    # two faces running the same way along (0, 1)
    assert [0, 1] in boundary_edges(np.array([[0, 1, 2], [0, 1, 3]])).tolist()


def _random_soup(draw_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A soup of 1-4 boxes and spheres: placed at random, some overlapping, some with
    faces taken out (holes), some inside out, some faces duplicated."""
    rng = np.random.default_rng(draw_seed)
    parts = []
    for _ in range(rng.integers(1, 5)):
        if rng.random() < 0.5:
            part = trimesh.creation.box(extents=rng.uniform(2, 8, 3))
        else:
            part = trimesh.creation.icosphere(subdivisions=2, radius=rng.uniform(1.5, 4))
        part.apply_translation(rng.uniform(-4, 4, 3))
        faces = np.asarray(part.faces)
        if rng.random() < 0.4:  # holes
            faces = faces[rng.random(len(faces)) > 0.15]
        if rng.random() < 0.3:  # inside out
            faces = faces[:, ::-1]
        if rng.random() < 0.3 and len(faces):  # duplicated faces
            faces = np.concatenate([faces, faces[rng.random(len(faces)) < 0.1]])
        parts.append((np.asarray(part.vertices), faces))
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.concatenate([v for v, _ in parts])
    faces = np.concatenate([f + o for (_, f), o in zip(parts, offsets, strict=True)])
    return vertices, faces.astype(np.int64)


@pytest.mark.parametrize("seed", range(8))
def test_random_soups_agree_with_libigl(seed):
    vertices, faces = _random_soup(seed)
    assert len(faces) > 0
    grid = _grid(vertices, (0.5, 0.55, 0.45))
    ours = solid_slab(soup_solid(vertices, faces), grid, 0, grid.shape_zyx[0])
    truth, distance = _libigl_inside(vertices, faces, grid)
    far = distance > 2 * np.linalg.norm(grid.voxel_mm)
    assert (ours.inside[far] == truth[far]).mean() >= 0.995
