from __future__ import annotations

import itertools

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from shellvox.voxel.geometry import winding_slab
from shellvox.voxel.grid import GridSpec


def _centres(grid: GridSpec) -> np.ndarray:
    z, y, x = np.meshgrid(*(np.arange(n) for n in grid.shape_zyx), indexing="ij")
    return grid.index_to_world(np.stack([z.ravel(), y.ravel(), x.ravel()], axis=1))


def _convex_reference(mesh: trimesh.Trimesh, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inside a convex mesh = behind every face plane; also return distance to nearest plane."""
    signed = np.einsum(
        "nfk,fk->nf", points[:, None, :] - mesh.triangles[None, :, 0, :], mesh.face_normals
    )
    return np.all(signed < 0, axis=1), np.abs(signed).min(axis=1)


def _full(mesh: trimesh.Trimesh, grid: GridSpec) -> np.ndarray:
    result = winding_slab(mesh.vertices, mesh.faces.astype(np.int64), grid, 0, grid.shape_zyx[0])
    assert result.n_unbalanced_rows == 0
    return result.winding


def test_box_on_grid_nodes_is_half_open():
    # vertices exactly on voxel centres: every tie rule is exercised
    box = trimesh.creation.box(bounds=[[1.0, 2.0, 3.0], [4.0, 6.0, 5.0]])
    grid = GridSpec((0.0, 0.0, 0.0), (0.5, 0.5, 0.5), (14, 16, 12))
    winding = _full(box, grid)
    expected = np.zeros(grid.shape_zyx, dtype=np.int16)
    # x: [2, 8) (crossing at a centre counts as beyond it); y, z perturbed by +e: [lo, hi)
    expected[6:10, 4:12, 2:8] = 1
    np.testing.assert_array_equal(winding, expected)


@settings(max_examples=15, deadline=None)
@given(
    st.floats(0.0, 2 * np.pi),
    st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3),
    st.sampled_from([(0.1, 0.1, 0.1), (0.0423, 0.0846, 0.027), (0.2, 0.07, 0.13)]),
)
def test_convex_mesh_matches_plane_test(angle, shift, voxel):
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(angle, [1, 2, 3]))
    mesh.apply_translation(shift)
    grid = GridSpec.from_bounds(mesh.bounds[0], mesh.bounds[1], voxel, margin_mm=0.1)
    if grid.n_voxels > 2_000_000:
        grid = GridSpec.from_bounds(
            mesh.bounds[0], mesh.bounds[1], (0.05, 0.1, 0.03), margin_mm=0.1
        )
    winding = _full(mesh, grid).ravel()
    inside, gap = _convex_reference(mesh, _centres(grid))
    clear = gap > 1e-9
    np.testing.assert_array_equal(winding[clear], inside[clear].astype(np.int16))
    assert set(np.unique(winding)) <= {0, 1}


def test_nested_and_nonconvex_surfaces():
    outer = trimesh.creation.annulus(r_min=1.0, r_max=3.0, height=2.0, sections=48)
    grid = GridSpec.from_bounds(outer.bounds[0], outer.bounds[1], (0.07, 0.09, 0.05), margin_mm=0.2)
    winding = _full(outer, grid)
    points = _centres(grid)
    radius = np.hypot(points[:, 0], points[:, 1])
    # polygonal annulus: inscribed/circumscribed radii bound the truth
    r_in_outer = 3.0 * np.cos(np.pi / 48)
    sure_in = (
        (radius > 1.0 + 1e-3) & (radius < r_in_outer - 1e-3) & (np.abs(points[:, 2]) < 1.0 - 1e-3)
    )
    sure_out = (
        (radius < 1.0 * np.cos(np.pi / 48) - 1e-3)
        | (radius > 3.0 + 1e-3)
        | (np.abs(points[:, 2]) > 1.0 + 1e-3)
    )
    flat = winding.ravel()
    assert np.all(flat[sure_in] == 1)
    assert np.all(flat[sure_out] == 0)


def test_slabs_concatenate_to_whole():
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=2.0)
    grid = GridSpec.from_bounds(mesh.bounds[0], mesh.bounds[1], (0.1, 0.13, 0.07), margin_mm=0.1)
    faces = mesh.faces.astype(np.int64)
    whole = winding_slab(mesh.vertices, faces, grid, 0, grid.shape_zyx[0]).winding
    cuts = [0, 5, 6, 31, grid.shape_zyx[0]]
    parts = [
        winding_slab(mesh.vertices, faces, grid, a, b).winding for a, b in itertools.pairwise(cuts)
    ]
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_open_mesh_reports_unbalanced_rows():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    faces = mesh.faces[1:].astype(np.int64)
    grid = GridSpec.from_bounds(mesh.bounds[0], mesh.bounds[1], (0.02, 0.02, 0.02), margin_mm=0.1)
    result = winding_slab(mesh.vertices, faces, grid, 0, grid.shape_zyx[0])
    assert result.n_unbalanced_rows > 0


def test_bad_input_rejected():
    grid = GridSpec((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (2, 2, 2))
    with pytest.raises(ValueError, match="vertices must be"):
        winding_slab(np.zeros((3, 2)), np.zeros((1, 3), np.int64), grid, 0, 1)
    with pytest.raises(ValueError, match="empty slab"):
        winding_slab(np.zeros((3, 3)), np.zeros((1, 3), np.int64), grid, 1, 1)
