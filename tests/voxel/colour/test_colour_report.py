"""The colour report's prediction from voxel columns against the model's own stack."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import trimesh

from shellvox.printer import load_profile
from shellvox.voxel.colour import (
    REACH_LIMITS_MM,
    ModelReport,
    colour_regions,
    lateral_reach,
    observer,
    r_infinity,
    reflectance_to_lab,
    sample_surface,
    saunderson,
    stack,
    summary,
)
from shellvox.voxel.grid import GridSpec

OPTICS = load_profile("j750").optics
MAGENTA, WHITE = OPTICS.roles.index("magenta"), OPTICS.roles.index("white")


def _box_case(depth_mm, voxel=0.05, read_mm=0.5):
    box = trimesh.creation.box((4.0, 4.0, 4.0))
    # centres at +-(2 - voxel / 2), ...: the faces lie between voxel centres
    first = -2.2 + voxel / 2
    grid = GridSpec((first,) * 3, (voxel,) * 3, (round(4.4 / voxel),) * 3)
    centres = grid.index_to_world(np.indices(grid.shape_zyx).reshape(3, -1).T)
    inside = np.all(np.abs(centres) < 2, axis=1)
    depth = 2 - np.abs(centres).max(axis=1)  # distance to the box surface inside
    materials = np.where(inside, np.where(depth < depth_mm, MAGENTA + 1, WHITE + 1), 0)
    samples = sample_surface(
        box.vertices,
        box.faces.astype(np.int64),
        lambda f, b: np.tile(np.array([200, 40, 40, 255], np.uint8), (len(f), 1)),
        3000,
        seed=3,
    )
    # columns (a disc of 0.25 mm, read_mm below the layer) inside the face's own pyramid
    tangential = np.abs(samples.points) * (1 - np.abs(samples.normals))
    keep = tangential.max(axis=1) < 2 - depth_mm - read_mm - 0.3
    return grid, materials.astype(np.uint8).reshape(grid.shape_zyx), samples, keep


def _expected(depth_mm):
    k, s = OPTICS.k_per_mm, OPTICS.s_per_mm
    body = stack(k[[MAGENTA]], s[[MAGENTA]], [depth_mm], r_infinity(k[WHITE], s[WHITE]))
    seen = observer(OPTICS.wavelengths_nm)
    return reflectance_to_lab(saunderson(body, OPTICS.k1, OPTICS.k2), seen)


@pytest.mark.parametrize("depth_mm", [0.05, 0.15, 1.0])
def test_a_layer_over_white_is_predicted_as_its_stack(depth_mm):
    grid, materials, samples, keep = _box_case(depth_mm)
    report = ModelReport(
        samples.points[keep], samples.normals[keep], grid, OPTICS, depth_mm=depth_mm + 0.5,
        bin_mm=0.05,
    )  # fmt: skip
    assert keep.sum() > 10
    report.add_slab(0, materials)
    error = colour.delta_E(report.predicted_lab(), _expected(depth_mm), method="CIE 2000")
    assert error.max() < 1e-6  # one voxel per depth bin: the column is the stack


def test_slabs_give_the_same_counts_however_cut():
    grid, materials, samples, _ = _box_case(0.3)
    whole = ModelReport(samples.points, samples.normals, grid, OPTICS)
    whole.add_slab(0, materials)
    cut = ModelReport(samples.points, samples.normals, grid, OPTICS)
    for z in range(0, grid.shape_zyx[0], 7):
        cut.add_slab(z, materials[z : z + 7])
    np.testing.assert_array_equal(whole.counts, cut.counts)
    aim = np.tile(_expected(0.3), (len(samples.points), 1))
    result = summary(cut.errors(aim, aim))
    assert result["samples_seen"] == len(samples.points)


def test_regions_name_lightness_and_hue():
    names = colour_regions(np.array([[250, 250, 250], [20, 20, 20], [220, 30, 30]], np.uint8))
    assert names.tolist() == ["light neutral", "dark neutral", "mid red"]


def test_a_sample_is_inside_its_colour_region_unless_near_an_edge():
    # A cube whose +x face is half red (y < 0) and half blue, its other faces a smooth
    # grey ramp along z: samples within the ring's reach of the red-blue edge are near an
    # edge; those farther away, and those on the ramp (it averages to its centre), inside.
    from shellvox.model import ColouredMesh
    from shellvox.stack import uniform_surroundings

    box = trimesh.creation.box((10.0, 10.0, 10.0)).subdivide().subdivide().subdivide()
    centre = box.triangles_center
    plus_x = box.face_normals[:, 0] > 0.5
    corner_z = box.vertices[box.faces][..., 2]  # (F, 3): a smooth ramp between corners
    grey = np.rint(120 + 10 * corner_z).astype(np.uint8)
    rgba = np.stack([grey, grey, grey, np.full_like(grey, 255)], axis=-1)
    rgba[plus_x & (centre[:, 1] < 0)] = (220, 30, 30, 255)
    rgba[plus_x & (centre[:, 1] >= 0)] = (30, 30, 220, 255)
    mesh = ColouredMesh(box.vertices, box.faces.astype(np.int64), "vertex", corner_rgba=rgba)
    samples = sample_surface(mesh.vertices, mesh.faces, mesh.colour_at, 3000, seed=1)
    radius = 0.35
    inside = uniform_surroundings(mesh, samples, np.full(len(samples.points), radius))
    on_x = samples.normals[:, 0] > 0.5
    y, z = samples.points[:, 1], samples.points[:, 2]
    away = np.minimum(5 - np.abs(y), 5 - np.abs(z))  # from the face's border
    assert not inside[on_x & (np.abs(y) < radius - 0.1) & (away > 0.5)].any()
    assert inside[on_x & (np.abs(y) > radius + 0.1) & (away > 0.5)].all()
    ramp = (
        (np.abs(samples.normals[:, 1]) > 0.5) & (np.abs(z) < 4) & (np.abs(samples.points[:, 0]) < 4)
    )
    assert inside[ramp].all()


def test_lateral_reach_is_longer_in_translucent_mixes_and_within_its_limits():
    white = lateral_reach(OPTICS.k_per_mm[[WHITE]], OPTICS.s_per_mm[[WHITE]], (0.0, 100.0))
    magenta = lateral_reach(OPTICS.k_per_mm[[MAGENTA]], OPTICS.s_per_mm[[MAGENTA]], (0.0, 100.0))
    band = int(np.argmax(r_infinity(OPTICS.k_per_mm[MAGENTA], OPTICS.s_per_mm[MAGENTA])))
    k, s = OPTICS.k_per_mm[MAGENTA, band], OPTICS.s_per_mm[MAGENTA, band]
    assert magenta[0] == pytest.approx(1 / np.sqrt(k * (k + 2 * s)))
    assert magenta[0] > 3 * white[0]
    clipped = lateral_reach(OPTICS.k_per_mm[[WHITE, MAGENTA]], OPTICS.s_per_mm[[WHITE, MAGENTA]])
    assert clipped.min() >= REACH_LIMITS_MM[0] and clipped.max() <= REACH_LIMITS_MM[1]


def test_rays_follow_a_curved_surface():
    # A cylinder (radius 2.5 mm, axis x) with 0.3 mm of magenta over white: with the
    # surface given, the columns of 1 mm discs on its side read the stack; in the tangent
    # plane alone they start in the air and cut the layer obliquely.
    from shellvox.voxel.geometry import SurfaceIndex

    radius, depth = 2.5, 0.3
    cylinder = trimesh.creation.cylinder(radius=radius, height=6.0, sections=256)
    cylinder.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    voxel = np.array([0.0423, 0.0846, 0.027])
    origin = np.array([-3.0, -2.8, -2.8])
    shape = tuple(int(v) for v in np.ceil(np.array([5.6, 5.6, 6.0])[::-1] / voxel[::-1]))
    grid = GridSpec(tuple(origin), tuple(voxel), shape)
    z, y = (
        (origin[2] + voxel[2] * np.arange(shape[0])),
        (origin[1] + voxel[1] * np.arange(shape[1])),
    )
    from_axis = np.hypot(z[:, None], y[None, :])  # (Z, Y): the same for every x
    layer = np.where(
        from_axis < radius, np.where(from_axis > radius - depth, MAGENTA + 1, WHITE + 1), 0
    )
    materials = np.ascontiguousarray(
        np.repeat(layer[:, :, None], shape[2], axis=2).astype(np.uint8)
    )
    rng = np.random.default_rng(5)
    angle = rng.uniform(0, 2 * np.pi, 60)
    normals = np.column_stack([np.zeros(60), np.cos(angle), np.sin(angle)])
    points = np.column_stack(
        [rng.uniform(-1.0, 1.0, 60), radius * normals[:, 1], radius * normals[:, 2]]
    )
    surface = SurfaceIndex.build(
        np.asarray(cylinder.vertices), np.asarray(cylinder.faces, np.int64)
    )
    expected = _expected(depth)
    errors = {}
    for name, given in (("curved", surface), ("plane", None)):
        report = ModelReport(points, normals, grid, OPTICS, disc_radius_mm=1.0, surface=given)
        report.add_slab(0, materials)
        errors[name] = colour.delta_E(report.predicted_lab(), expected, method="CIE 2000")
    assert np.median(errors["curved"]) < 0.3 and errors["curved"].max() < 0.6
    assert np.median(errors["plane"]) > 2 * np.median(errors["curved"])
