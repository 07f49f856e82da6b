"""The compiled nearest-face scan against libigl's AABB tree (an independent exact search)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.voxel.geometry import (
    SurfaceIndex,
    inside_slab,
    nearest_faces,
    nearest_in_reach,
    nearest_within,
    voronoi_regions,
    winding_slab,
)
from shellvox.voxel.grid import GridSpec


def _bumpy(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A closed, non-convex mesh with reflex edges and saddle vertices."""
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=2.0)
    rng = np.random.default_rng(seed)
    vertices = mesh.vertices * (1 + 0.25 * rng.random((len(mesh.vertices), 1)))
    return vertices, mesh.faces.astype(np.int64)


def _grid(vertices: np.ndarray, voxel: tuple[float, float, float]) -> GridSpec:
    return GridSpec.from_bounds(vertices.min(axis=0), vertices.max(axis=0), voxel, margin_mm=0.6)


def _centres(grid: GridSpec, z_start: int, z_stop: int) -> np.ndarray:
    shape = (z_stop - z_start, *grid.shape_zyx[1:])
    index = np.stack(np.unravel_index(np.arange(np.prod(shape)), shape), axis=1)
    index[:, 0] += z_start
    return grid.index_to_world(index)


@pytest.mark.parametrize(
    ("mesh", "voxel", "reach"),
    [
        ("bumpy", (0.06, 0.11, 0.045), 0.5),
        ("bumpy", (0.1, 0.1, 0.1), 1.3),
        ("box", (0.07, 0.05, 0.09), 0.8),
        ("open", (0.05, 0.08, 0.06), 0.4),
    ],
)
def test_matches_the_aabb_tree(mesh: str, voxel: tuple[float, float, float], reach: float) -> None:
    if mesh == "bumpy":
        vertices, faces = _bumpy()
    elif mesh == "box":  # coplanar faces: flat edges, axis-aligned planes
        box = trimesh.creation.box(extents=(2.0, 3.0, 1.5))
        box = box.subdivide()
        vertices, faces = box.vertices, box.faces.astype(np.int64)
    else:  # an open surface with a zero-area face (a duplicated corner) added
        sheet = trimesh.creation.icosphere(subdivisions=2, radius=1.5)
        keep = sheet.triangles_center[:, 2] < 0.4
        vertices = sheet.vertices
        faces = np.concatenate([sheet.faces[keep], [[0, 0, 1]]]).astype(np.int64)
    grid = _grid(vertices, voxel)
    n_z = grid.shape_zyx[0]
    z_start, z_stop = n_z // 3, n_z // 3 + 7
    near = nearest_in_reach(vertices, faces, grid, z_start, z_stop, reach)
    points = _centres(grid, z_start, z_stop)
    surface = SurfaceIndex.build(vertices, faces[np.any(faces != faces[:, :1], axis=1)])
    _, distance = nearest_faces(surface, points)
    distance = distance.reshape(near.face.shape)
    found = near.face >= 0
    clear = np.abs(distance - reach) > 1e-9
    np.testing.assert_array_equal(found[clear], (distance < reach)[clear])
    np.testing.assert_allclose(np.sqrt(near.squared_mm2[found]), distance[found], atol=1e-12)
    # the face given is one at that distance (exactly, by the slow reference formula)
    chosen = near.face[found]
    tri = vertices[faces[chosen]]
    own = np.array(
        [
            trimesh.triangles.closest_point(t[None], p[None])[0]
            for t, p in zip(tri[:2000], points[found.ravel()][:2000], strict=True)
        ]
    )
    mine = np.linalg.norm(own - points[found.ravel()][:2000], axis=1)
    np.testing.assert_allclose(mine, distance[found][:2000], atol=1e-9)


def test_slabs_equal_the_whole_and_ties_take_the_lowest_face() -> None:
    vertices, faces = _bumpy(1)
    grid = _grid(vertices, (0.08, 0.12, 0.05))
    n_z = grid.shape_zyx[0]
    whole = nearest_in_reach(vertices, faces, grid, 0, n_z, 0.7)
    for start, stop in ((0, 5), (5, 37), (37, n_z)):
        part = nearest_in_reach(vertices, faces, grid, start, stop, 0.7)
        np.testing.assert_array_equal(part.face, whole.face[start:stop])
        np.testing.assert_array_equal(part.squared_mm2, whole.squared_mm2[start:stop])
    # two copies of one triangle: every voxel ties, the lower index wins
    tri = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    twin = GridSpec((0.0, 0.0, -0.3), (0.1, 0.1, 0.1), (7, 11, 11))
    near = nearest_in_reach(tri, np.array([[0, 1, 2], [0, 1, 2]]), twin, 0, 7, 0.35)
    assert set(np.unique(near.face)) == {-1, 0}


def test_inside_reach_and_wanted_voxels() -> None:
    vertices, faces = _bumpy(2)
    grid = _grid(vertices, (0.09, 0.09, 0.07))
    n_z = grid.shape_zyx[0]
    inside, unbalanced = inside_slab(vertices, faces, grid, 10, 20)
    assert unbalanced == 0
    np.testing.assert_array_equal(inside, winding_slab(vertices, faces, grid, 10, 20).winding > 0)
    near = nearest_in_reach(vertices, faces, grid, 10, 20, 0.6, inside, 0.1)
    _, distance = nearest_faces(SurfaceIndex.build(vertices, faces), _centres(grid, 10, 20))
    distance = distance.reshape(inside.shape)
    wanted = np.where(inside, distance < 0.6, distance < 0.1)
    clear = np.abs(distance - np.where(inside, 0.6, 0.1)) > 1e-9
    np.testing.assert_array_equal((near.face >= 0)[clear], wanted[clear])
    # only the voxels asked for (reach 0 elsewhere) are answered
    ask = np.zeros(inside.shape)
    ask[3, 10:20, 5:40] = 0.8**2
    only = nearest_within(vertices, faces, grid, 10, ask, voronoi_regions(vertices, faces))
    assert np.all(only.face[ask == 0] == -1)
    assert n_z > 20


def test_voronoi_spread_holds_the_region_directions() -> None:
    vertices, faces = _bumpy(3)
    regions = voronoi_regions(vertices, faces)
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(4000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for n in rng.choice(np.flatnonzero(regions.kind > 0), 300, replace=False):
        bounds = regions.bounds[regions.bounds_ptr[n] : regions.bounds_ptr[n + 1], :3]
        inside = directions[np.all(directions @ bounds.T <= 0, axis=1)]
        assert np.all(inside >= regions.spread[n, :3] - 1e-12)
        assert np.all(inside <= regions.spread[n, 3:] + 1e-12)
