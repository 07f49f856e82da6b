from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.voxel.geometry import SurfaceIndex
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import StackModel, compute_slab


def _sphere(radius: float) -> tuple[np.ndarray, np.ndarray]:
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=radius)
    return mesh.vertices, mesh.faces.astype(np.int64)


def _face_colour(vertices: np.ndarray, faces: np.ndarray):
    """Colour = 8-bit quantised direction of the face centroid (no averaging possible)."""
    centroids = vertices[faces].mean(axis=1)
    rgb = np.round((centroids / np.linalg.norm(centroids, axis=1)[:, None] + 1) * 127.5)
    rgba = np.concatenate([rgb, np.full((len(faces), 1), 255.0)], axis=1).astype(np.uint8)

    def colour_at(face_ids, barycentric):
        return rgba[face_ids]

    return colour_at, rgba


@pytest.fixture
def nested():
    outer = _sphere(3.0)
    surfaces = (outer, _sphere(2.5), _sphere(2.0))
    colour_at, rgba = _face_colour(*outer)
    model = StackModel(
        surfaces,
        SurfaceIndex.build(*outer),
        colour_at,
        colour_layers=(1,),
        sdf_half_width_mm=0.3,
    )
    grid = GridSpec.from_bounds([-3, -3, -3], [3, 3, 3], (0.1, 0.12, 0.08), margin_mm=0.4)
    return model, grid, rgba


def test_layers_match_radii(nested):
    model, grid, _ = nested
    result = compute_slab(model, grid, 0, grid.shape_zyx[0])
    assert result.n_unbalanced_rows == 0
    assert result.n_nesting_violations == 0
    z, y, x = np.meshgrid(*(np.arange(n) for n in grid.shape_zyx), indexing="ij")
    centres = grid.index_to_world(np.stack([z.ravel(), y.ravel(), x.ravel()], axis=1))
    radius = np.linalg.norm(centres, axis=1)
    expected = (radius < 3.0).astype(int) + (radius < 2.5) + (radius < 2.0)
    # icosphere facets sit inside the sphere by at most r * (1 - cos(edge angle / 2))
    sure = np.min(np.abs(radius[:, None] - np.array([3.0, 2.5, 2.0])), axis=1) > 0.02
    np.testing.assert_array_equal(result.layers.ravel()[sure], expected[sure])


def test_colour_is_exact_nearest_face_colour(nested):
    model, grid, rgba = nested
    result = compute_slab(model, grid, 20, 40)
    colour_voxels = result.layers == 1
    assert np.all(result.rgba[~colour_voxels] == 0)
    z, y, x = np.nonzero(colour_voxels)
    centres = grid.index_to_world(np.stack([z + 20, y, x], axis=1))
    mesh = trimesh.Trimesh(*_sphere(3.0), process=False)
    _, _, face = trimesh.proximity.closest_point(mesh, centres)
    got = result.rgba[colour_voxels]
    # every colour is one of the surface colours (never averaged), and the nearest one
    agree = np.all(got == rgba[face], axis=1)
    assert agree.mean() > 0.999


def test_sdf_band(nested):
    model, grid, _ = nested
    result = compute_slab(model, grid, 0, grid.shape_zyx[0])
    z, y, x = np.nonzero(result.sdf_band)
    pick = np.random.default_rng(0).choice(len(z), size=min(len(z), 3000), replace=False)
    z, y, x = z[pick], y[pick], x[pick]
    centres = grid.index_to_world(np.stack([z, y, x], axis=1))
    mesh = trimesh.Trimesh(*_sphere(3.0), process=False)
    reference = -trimesh.proximity.signed_distance(mesh, centres)  # trimesh: positive inside
    np.testing.assert_allclose(result.sdf[z, y, x], reference, atol=1e-5)
    assert np.all(np.abs(result.sdf[result.sdf_band]) < 0.3)
    # every voxel closer than the half width is in the band
    all_idx = np.stack(np.nonzero(np.ones(grid.shape_zyx, bool)), axis=1)
    distance = np.abs(np.linalg.norm(grid.index_to_world(all_idx), axis=1) - 3.0)
    assert np.all(result.sdf_band.ravel()[distance < 0.25])


def test_slabs_equal_whole(nested):
    model, grid, _ = nested
    whole = compute_slab(model, grid, 0, grid.shape_zyx[0])
    parts = [
        compute_slab(model, grid, a, b) for a, b in ((0, 30), (30, 31), (31, grid.shape_zyx[0]))
    ]
    for name in ("layers", "rgba", "sdf", "sdf_band"):
        np.testing.assert_array_equal(
            np.concatenate([getattr(p, name) for p in parts]), getattr(whole, name)
        )


def test_bad_options(nested):
    model, grid, _ = nested
    with pytest.raises(ValueError, match=r"colour_layers must lie in 1\.\.3"):
        StackModel(model.surfaces, model.surface, model.colour_at, colour_layers=(4,))
    with pytest.raises(ValueError, match="slab rows"):
        compute_slab(model, grid, 5, 5)


def _box_model(depth_per_face: np.ndarray, colour_layers=(1,)):
    box = trimesh.creation.box(extents=(6.0, 6.0, 6.0))
    faces = box.faces.astype(np.int64)
    colour_at, _ = _face_colour(box.vertices, faces)
    return StackModel(
        ((box.vertices, faces),),
        SurfaceIndex.build(box.vertices, faces),
        colour_at,
        colour_layers=colour_layers,
        depth_mm=depth_per_face,
        layer_rule="distance",
    ), box


def test_distance_layers_follow_the_nearest_face_depth():
    """Box with another depth per side: analytic distance to the nearest side plane."""
    _, box = _box_model(np.ones((2, 12)))
    normals = box.face_normals
    side = np.argmax(np.abs(normals), axis=1) * 2 + (normals.max(axis=1) > 0.5)
    side_depth = np.array([[0.4, 0.5, 0.6, 0.7, 0.8, 0.9], [1.1, 1.3, 1.2, 1.6, 1.5, 1.4]])
    model, _ = _box_model(side_depth[:, side])
    grid = GridSpec.from_bounds([-3, -3, -3], [3, 3, 3], (0.07, 0.11, 0.05), margin_mm=0.3)
    result = compute_slab(model, grid, 0, grid.shape_zyx[0])
    idx = np.stack(np.nonzero(np.ones(grid.shape_zyx, bool)), axis=1)
    centres = grid.index_to_world(idx)
    # distance to each side plane: side 2a is -axis a, side 2a+1 is +axis a
    gaps = np.stack(
        [
            3.0 + centres[:, 0],
            3.0 - centres[:, 0],
            3.0 + centres[:, 1],
            3.0 - centres[:, 1],
            3.0 + centres[:, 2],
            3.0 - centres[:, 2],
        ],
        axis=1,
    )
    inside = np.all(gaps > 0, axis=1)
    nearest_side = np.argmin(gaps, axis=1)
    d = gaps.min(axis=1)
    depth = side_depth[:, nearest_side]
    expected = np.where(inside, 1 + (d[None] >= depth).sum(axis=0), 0)
    ordered = np.sort(gaps, axis=1)
    clear = (ordered[:, 1] - ordered[:, 0] > 1e-9) & np.all(np.abs(d[None] - depth) > 1e-9, axis=0)
    clear &= np.abs(d) > 1e-9
    got = result.layers.reshape(-1)
    np.testing.assert_array_equal(got[clear], expected[clear])
    assert set(np.unique(got)) == {0, 1, 2, 3}


def test_distance_and_shell_realisations_agree(nested):
    model, grid, _ = nested
    shells = compute_slab(model, grid, 0, grid.shape_zyx[0])
    by_distance = StackModel(
        model.surfaces[:1],
        model.surface,
        model.colour_at,
        colour_layers=(1,),
        sdf_half_width_mm=0.3,
        depth_mm=np.tile([[0.5], [1.0]], (1, len(model.surfaces[0][1]))),
        layer_rule="distance",
    )
    result = compute_slab(by_distance, grid, 0, grid.shape_zyx[0])
    idx = np.stack(np.nonzero(np.ones(grid.shape_zyx, bool)), axis=1)
    radius = np.linalg.norm(grid.index_to_world(idx), axis=1)
    # icosphere facets lie within 0.02 mm of the spheres; offsets of a facetted sphere
    # differ from the smaller icospheres by as much again
    sure = np.min(np.abs(radius[:, None] - np.array([3.0, 2.5, 2.0])), axis=1) > 0.05
    np.testing.assert_array_equal(result.layers.ravel()[sure], shells.layers.ravel()[sure])
    for name in ("sdf", "sdf_band"):
        np.testing.assert_array_equal(getattr(result, name), getattr(shells, name))
    colour = result.layers == 1
    same = colour & (shells.layers == 1)
    np.testing.assert_array_equal(result.rgba[same], shells.rgba[same])
    assert np.all(result.rgba[~colour] == 0)


def test_distance_slabs_equal_whole_and_colour_the_core():
    model, _ = _box_model(np.tile([[0.5], [1.0]], (1, 12)), colour_layers=(1, 3))
    grid = GridSpec.from_bounds([-3, -3, -3], [3, 3, 3], (0.2, 0.25, 0.15), margin_mm=0.3)
    whole = compute_slab(model, grid, 0, grid.shape_zyx[0])
    parts = [compute_slab(model, grid, a, b) for a, b in ((0, 17), (17, grid.shape_zyx[0]))]
    np.testing.assert_array_equal(np.concatenate([p.layers for p in parts]), whole.layers)
    np.testing.assert_array_equal(np.concatenate([p.rgba for p in parts]), whole.rgba)
    coloured = np.isin(whole.layers, [1, 3])
    assert np.all(whole.rgba[coloured][:, 3] == 255)
    assert np.all(whole.rgba[~coloured] == 0)


def test_bad_depth(nested):
    model, _, _ = nested
    n_faces = len(model.surfaces[0][1])
    for bad in (np.ones((2, n_faces - 1)), np.array([[1.0] * n_faces, [0.5] * n_faces])):
        with pytest.raises(ValueError, match="depth_mm must be"):
            StackModel(
                model.surfaces[:1],
                model.surface,
                model.colour_at,
                depth_mm=bad,
                layer_rule="distance",
            )
    with pytest.raises(ValueError, match="depth_mm must be given with layer_rule 'distance'"):
        StackModel(model.surfaces[:1], model.surface, model.colour_at, layer_rule="distance")
    with pytest.raises(ValueError, match="depth_mm must be given with layer_rule 'distance'"):
        StackModel(model.surfaces, model.surface, model.colour_at, depth_mm=np.ones((2, n_faces)))
