"""Block distance bounds against the analytic distance to a box surface."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from voxel.blocks import block_bounds, fine_block_size
from voxel.grid import GridSpec
from voxel.nearest import SurfaceIndex, distance_to_surface


def _box_distance(points: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Exact unsigned distance of points (N, 3) to the surface of the box |x| <= half."""
    q = np.abs(points) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = -np.minimum(q.max(axis=1), 0.0)
    return outside + inside


@pytest.fixture(scope="module")
def box():
    half = np.array([2.0, 1.5, 1.0])
    mesh = trimesh.creation.box(extents=2 * half)
    surface = SurfaceIndex.build(mesh.vertices, mesh.faces.astype(np.int64))
    grid = GridSpec.from_bounds(-half, half, (0.07, 0.11, 0.05), margin_mm=0.6)
    return half, surface, grid


@pytest.mark.parametrize(("z_start", "z_stop", "reach"), [(0, 64, 0.8), (13, 47, 0.3), (5, 6, 1.9)])
def test_bounds_hold_for_every_voxel(box, z_start, z_stop, reach):
    half, surface, grid = box
    bounds = block_bounds(surface, grid, z_start, z_stop, reach)
    shape = (z_stop - z_start, grid.shape_zyx[1], grid.shape_zyx[2])
    idx = np.stack(np.unravel_index(np.arange(int(np.prod(shape))), shape), axis=1)
    idx[:, 0] += z_start
    exact = _box_distance(grid.index_to_world(idx), half).reshape(shape)
    lower = bounds.expand(bounds.lower_mm, shape)
    upper = bounds.expand(bounds.upper_mm, shape)
    finite = np.isfinite(lower)
    assert np.all(lower[finite] <= exact[finite] + 1e-12)
    assert np.all(exact[finite] <= upper[finite] + 1e-12)
    # blocks left at infinity are truly beyond the reach
    assert np.all(exact[~finite] > reach)
    # the bounds are tight: their width is the fine block's diagonal
    size = np.array(bounds.size)
    diagonal = np.linalg.norm((size - 1) * np.array(grid.voxel_mm[::-1]))
    assert np.all(upper[finite] - lower[finite] <= diagonal + 1e-8)
    # fewer queries than voxels
    assert bounds.n_queries < exact.size / 4


def test_distance_matches_trimesh(box):
    _, surface, _ = box
    points = np.random.default_rng(1).uniform(-3, 3, size=(500, 3))
    mesh = trimesh.Trimesh(surface.vertices, surface.faces, process=False)
    reference = trimesh.proximity.closest_point(mesh, points)[1]
    np.testing.assert_allclose(distance_to_surface(surface, points), reference, atol=1e-9)


def test_fine_block_size_is_anisotropic(box):
    _, _, grid = box
    bz, by, bx = fine_block_size(grid, 2.0)
    assert (bz, by, bx) == (round(0.3 / 0.05), round(0.3 / 0.11), round(0.3 / 0.07))
    # never below two of the largest voxel edge (0.11 mm)
    assert fine_block_size(grid, 1e-6) == (round(0.22 / 0.05), 2, round(0.22 / 0.07))
    with pytest.raises(ValueError, match="reach_mm"):
        block_bounds(*box[1:], 0, 1, 0.0)
