"""Property: on a convex polytope the offset is the intersection of the moved half-spaces."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection, cKDTree

from shellvox.offset import offset_shells


def _polytope(seed: int, n_points: int) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n_points, 3)) * rng.uniform(2.0, 10.0, size=3)
    return trimesh.convex.convex_hull(pts)


def _chebyshev(normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of the largest ball in ``n . x <= c`` (linear programming)."""
    norm = np.linalg.norm(normals, axis=1)
    lp = linprog(
        c=[0, 0, 0, -1],
        A_ub=np.hstack([normals, norm[:, None]]),
        b_ub=offsets,
        bounds=[(None, None)] * 3 + [(0, None)],
    )
    assert lp.status == 0
    return lp.x[:3], float(lp.x[3])


def _moved_halfspace_polytope(mesh: trimesh.Trimesh, depth: np.ndarray) -> np.ndarray:
    normals = np.asarray(mesh.face_normals)
    offsets = np.einsum("ij,ij->i", normals, mesh.triangles[:, 0]) - depth
    halfspaces = np.hstack([normals, -offsets[:, None]])  # n . x - c <= 0
    centre, radius = _chebyshev(normals, offsets)  # an interior point
    assert radius > 1e-3, "the moved half-spaces must leave a solid"
    return HalfspaceIntersection(halfspaces, centre).intersections


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_points=st.integers(8, 60), frac=st.floats(0.05, 0.6))
def test_random_convex_polytope_offset_is_moved_halfspaces(seed, n_points, frac):
    mesh = _polytope(seed, n_points)
    inradius = float(trimesh.proximity.signed_distance(mesh, [mesh.centroid])[0])
    d = frac * abs(inradius)
    # Moving every unit-normal half-space in by d shrinks the largest inscribed ball by d,
    # so d <= 0.6 * (a distance from the centroid) always leaves a solid.
    normals = np.asarray(mesh.face_normals)
    plane = np.einsum("ij,ij->i", normals, mesh.triangles[:, 0])
    radius = _chebyshev(normals, plane)[1]
    assert _chebyshev(normals, plane - d)[1] == pytest.approx(radius - d, rel=1e-6)
    (shell,) = offset_shells(mesh.vertices, mesh.faces, [d], method="robust")
    corners = _moved_halfspace_polytope(mesh, np.full(len(mesh.faces), d))
    expected = ConvexHull(corners)
    got = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
    assert got.is_watertight
    assert got.is_winding_consistent
    assert got.volume == pytest.approx(expected.volume, rel=1e-9)
    # Every expected corner is a shell vertex; every shell vertex is on the moved hull.
    gap, _ = cKDTree(shell.vertices).query(corners)
    assert gap.max() <= 1e-9 * mesh.scale
    slack = (shell.vertices @ normals.T - (plane - d)).max(axis=1)
    assert np.abs(slack).max() <= 1e-9 * mesh.scale


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_variable_depth_on_a_polytope_where_every_point_projects_inside(seed):
    """Every interior point of a box projects into every square face, so per-face depths
    give exactly the moved half-spaces (both triangles of a square share the depth)."""
    cube = trimesh.creation.box((4.0, 5.0, 6.0))
    rng = np.random.default_rng(seed)
    per_square = rng.uniform(0.1, 1.9, size=6)
    key = np.argmax(np.abs(cube.face_normals), axis=1) * 2 + (cube.face_normals.sum(axis=1) > 0)
    depth = per_square[key]
    (shell,) = offset_shells(cube.vertices, cube.faces, depth[None, :], method="robust")
    corners = _moved_halfspace_polytope(cube, depth)
    got = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
    assert got.is_watertight
    assert got.volume == pytest.approx(ConvexHull(corners).volume, rel=1e-9)
