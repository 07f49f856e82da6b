"""The thickness rule: known colours give the thickness the documented formula gives
(with CIELAB computed here by colour-science), smoothing stays in range and matches a
slow reference, curvature matches spheres, and bad TOML is refused by file and key."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import colour
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from shellvox.errors import InputError
from shellvox.model import ColouredMesh, Material, face_areas
from shellvox.thickness import (
    DEFAULT_RULE,
    LIGHTNESS_RULE,
    ColourLayerRule,
    CurvatureRule,
    LayersRule,
    SmoothingRule,
    face_colour,
    face_thickness,
    load_rule,
    mean_curvature,
    smooth_over_distance,
    split_faces,
    thickness_summary,
)

#: The lightness rule, whose formula the tests below write out independently.
NO_SMOOTHING_NO_CAP = dataclasses.replace(
    LIGHTNESS_RULE,
    curvature=CurvatureRule(max_depth_per_radius=0.0),
    smoothing=SmoothingRule(radius_mm=0.0),
)


def lab_of(rgb_uint8):
    """CIELAB (D65) of sRGB uint8 colours, straight from colour-science."""
    return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(np.asarray(rgb_uint8, float) / 255.0))


def expected_thickness(rgba, normal_z, rule):
    """The module docstring's formula, written out independently."""
    lab = lab_of(rgba[:, :3])
    lightness = lab[:, 0]
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    alpha = rgba[:, 3] / 255.0
    c, o = rule.colour_layer, rule.orientation
    score = (
        c.lightness_weight * lightness / 100
        + c.neutral_weight * (1 - np.minimum(chroma / c.full_chroma, 1))
        + c.transparency_weight * (1 - alpha)
    ) / (c.lightness_weight + c.neutral_weight + c.transparency_weight)
    factor = np.where(
        normal_z > o.upper_min_normal_z,
        o.upper_factor,
        np.where(normal_z < o.lower_max_normal_z, o.lower_factor, o.side_factor),
    )
    return np.clip((c.min_mm + (c.max_mm - c.min_mm) * score) * factor, c.min_mm, c.max_mm)


def face_coloured(mesh: trimesh.Trimesh, rgba: np.ndarray) -> ColouredMesh:
    return ColouredMesh(
        np.asarray(mesh.vertices, float),
        np.asarray(mesh.faces, np.int64),
        "face",
        face_rgba=np.asarray(rgba, np.uint8),
    )


def test_known_face_colours_get_the_rules_thickness():
    sphere = trimesh.creation.icosphere(2, 20.0)  # normals of every direction
    rng = np.random.default_rng(1)
    rgba = rng.integers(0, 256, (len(sphere.faces), 4)).astype(np.uint8)
    rgba[:10] = [[255, 255, 255, 255], [0, 0, 0, 255], [255, 0, 0, 255], [0, 0, 255, 128]] + [
        [128, 128, 128, 0]
    ] * 6
    mesh = face_coloured(sphere, rgba)
    result = face_thickness(mesh, NO_SMOOTHING_NO_CAP)
    expected = expected_thickness(rgba, sphere.face_normals[:, 2], NO_SMOOTHING_NO_CAP)
    np.testing.assert_allclose(result.colour_layer_mm, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.thickness_mm[0], expected, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(result.thickness_mm[1], 0.5)  # the default backing
    assert result.thickness_mm.shape == (2, len(sphere.faces))


def test_documented_default_values():
    """The numbers quoted in the lightness rule's docstring (upper surfaces, opaque)."""
    colours = {
        "white": ([255, 255, 255], 1.02),
        "mid grey": ([128, 128, 128], 0.77),
        "yellow": ([255, 255, 0], 0.83),
        "red": ([255, 0, 0], 0.59),
        "black": ([0, 0, 0], 0.48),
    }
    rgba = np.array([[*rgb, 255] for rgb, _ in colours.values()], np.uint8)
    got = expected_thickness(rgba, np.ones(len(rgba)), LIGHTNESS_RULE)
    np.testing.assert_allclose(got, [t for _, t in colours.values()], atol=0.005)
    clear_white = expected_thickness(np.array([[255, 255, 255, 0]]), np.ones(1), LIGHTNESS_RULE)
    assert clear_white[0] == pytest.approx(LIGHTNESS_RULE.colour_layer.max_mm, abs=1e-4)


@pytest.mark.parametrize("normal_z", [1.0, 0.0, -1.0])
def test_lightness_rule_white_is_thicker_than_black(normal_z):
    box = trimesh.creation.box((30.0, 30.0, 30.0))
    white = face_thickness(face_coloured(box, np.full((12, 4), 255, np.uint8)), LIGHTNESS_RULE)
    black_rgba = np.zeros((12, 4), np.uint8)
    black_rgba[:, 3] = 255
    black = face_thickness(face_coloured(box, black_rgba), LIGHTNESS_RULE)
    chosen = np.isclose(box.face_normals[:, 2], normal_z)
    # "Measurably" deeper: at least a third of a millimetre, about 4 J750 side voxels.
    assert np.all(white.colour_layer_mm[chosen] > black.colour_layer_mm[chosen] + 0.3)


def test_lighter_less_saturated_more_transparent_is_thicker():
    box = trimesh.creation.box((30.0, 30.0, 30.0))
    pairs = [  # (thinner, thicker)
        ([40, 40, 40, 255], [200, 200, 200, 255]),  # lighter
        ([230, 20, 20, 255], [180, 110, 110, 255]),  # less saturated at about the same L*
        ([90, 140, 200, 255], [90, 140, 200, 100]),  # more transparent
    ]
    for thin, thick in pairs:
        a = face_thickness(face_coloured(box, np.tile(thin, (12, 1))), NO_SMOOTHING_NO_CAP)
        b = face_thickness(face_coloured(box, np.tile(thick, (12, 1))), NO_SMOOTHING_NO_CAP)
        assert np.all(b.colour_layer_mm > a.colour_layer_mm)


def test_layers_rule_places_colour_and_backing_layers():
    rule = dataclasses.replace(
        LIGHTNESS_RULE, layers=LayersRule(colour=(2,), backing_mm=(0.2, 0.7))
    )
    box = trimesh.creation.box((30.0, 30.0, 30.0))
    result = face_thickness(face_coloured(box, np.full((12, 4), 255, np.uint8)), rule)
    np.testing.assert_array_equal(result.thickness_mm[0], 0.2)
    np.testing.assert_array_equal(result.thickness_mm[1], result.colour_layer_mm)
    np.testing.assert_array_equal(result.thickness_mm[2], 0.7)


def _reference_smoothing(centroids, normals, areas, values, radius):
    """Every pair of faces, one at a time: the slow, obvious version."""
    out = np.empty(len(values))
    for f in range(len(values)):
        weight = area = 0.0
        for g in range(len(values)):
            distance = float(np.linalg.norm(centroids[f] - centroids[g]))
            if g == f:
                w = 1.0
            elif distance < radius and float(normals[f] @ normals[g]) > 0:
                w = 1.0 - distance / radius
            else:
                continue
            weight += w * areas[g] * values[g]
            area += w * areas[g]
        out[f] = weight / area
    return out


def _random_closed_mesh(seed: int) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(int(rng.integers(8, 60)), 3)) * rng.uniform(1, 20, 3)
    return trimesh.convex.convex_hull(points)


def test_smoothing_matches_a_slow_reference():
    mesh = trimesh.creation.icosphere(2, 5.0)
    values = np.random.default_rng(0).uniform(0.3, 1.2, len(mesh.faces))
    args = (mesh.triangles_center, mesh.face_normals, mesh.area_faces, values, 2.0)
    expected = _reference_smoothing(*args)
    np.testing.assert_allclose(smooth_over_distance(*args), expected, rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    low=st.floats(0.01, 2.0),
    span=st.floats(0.0, 3.0),
    radius=st.floats(0.0, 30.0),
)
def test_smoothing_never_leaves_the_range(seed, low, span, radius):
    mesh = _random_closed_mesh(seed)
    high = low + span
    rng = np.random.default_rng(seed)
    values = rng.choice([low, high], len(mesh.faces))  # extremes: the hardest case
    values[rng.random(len(values)) < 0.3] = rng.uniform(low, high)
    got = smooth_over_distance(
        mesh.triangles_center, mesh.face_normals, mesh.area_faces, values, radius
    )
    slack = 1e-12 * max(high, 1.0)
    assert got.min() >= low - slack and got.max() <= high + slack


@pytest.mark.parametrize("subdivisions", [0, 2, 4])
def test_a_box_keeps_each_sides_depth_however_triangulated(subdivisions):
    # The box: 20 x 20 x 10 mm, sides of different colours; the rule's value per
    # side, the same for 12 triangles and for the box subdivided.
    box = trimesh.creation.box((20.0, 20.0, 10.0))
    for _ in range(subdivisions):
        box = box.subdivide()
    side = np.argmax(np.abs(box.face_normals), axis=1) * 2 + (box.face_normals.max(1) > 0.5)
    palette = np.array(
        [[255, 255, 255, 255], [200, 200, 200, 255], [80, 80, 80, 255], [0, 0, 0, 255],
         [230, 120, 40, 255], [40, 160, 220, 255]],
        np.uint8,
    )  # fmt: skip
    mesh = face_coloured(box, palette[side])
    # smoothing on (1 mm), the curvature cap off (it is about corners, not triangulation)
    rule = dataclasses.replace(LIGHTNESS_RULE, curvature=CurvatureRule(max_depth_per_radius=0.0))
    got = face_thickness(mesh, rule)
    own = expected_thickness(palette[side], box.face_normals[:, 2], rule)
    np.testing.assert_allclose(got.colour_layer_mm, own, atol=1e-9)


def test_smoothed_default_thickness_stays_in_range_on_a_textured_model(tmp_path):
    sphere = trimesh.creation.icosphere(3, 15.0)
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, (64, 64, 4)).astype(np.uint8)
    corner_uv = rng.random((len(sphere.faces), 3, 2))
    mesh = ColouredMesh(
        np.asarray(sphere.vertices),
        np.asarray(sphere.faces, np.int64),
        "texture",
        corner_uv=corner_uv,
        face_material=np.zeros(len(sphere.faces), np.int64),
        materials=(Material("noise", image=image),),
    )
    result = face_thickness(mesh, LIGHTNESS_RULE)
    layer = LIGHTNESS_RULE.colour_layer
    assert result.colour_layer_mm.min() >= layer.min_mm
    assert result.colour_layer_mm.max() <= layer.max_mm
    assert np.abs(result.colour_layer_mm - result.unsmoothed_mm).max() > 0  # it did smooth
    assert np.all(result.colour_layer_mm >= result.unsmoothed_mm)  # never below the need


@pytest.mark.parametrize(("radius", "subdivisions"), [(1.5, 4), (5.0, 5), (20.0, 5)])
def test_mean_curvature_of_a_sphere_is_one_over_its_radius(radius, subdivisions):
    sphere = trimesh.creation.icosphere(subdivisions, radius)
    curvature = mean_curvature(np.asarray(sphere.vertices), np.asarray(sphere.faces), 1.0)
    np.testing.assert_allclose(curvature, 1.0 / radius, rtol=0.01)


def test_mean_curvature_of_a_box_keeps_the_total_and_spreads_each_edge():
    box = trimesh.creation.box((40.0, 10.0, 10.0))
    mesh = split_faces(face_coloured(box, np.zeros((12, 4), np.uint8)), 1.0).mesh
    curvature = mean_curvature(mesh.vertices, mesh.faces, 1.0)
    areas = face_areas(mesh.vertices, mesh.faces)
    # Total mean curvature of a box: sum over its edges of (pi / 2) |e| / 2.
    edges_mm = 4 * (40.0 + 10.0 + 10.0)
    np.testing.assert_allclose((curvature * areas).sum(), np.pi / 4 * edges_mm, rtol=1e-5)
    # On the y = +-5 faces away from the ends, each long edge at distance g adds
    # pi / (8 r) exp(-g / r) (the 1D kernel of 1 - r^2 d^2/dg^2 on both sides of it).
    centres = mesh.triangles.mean(axis=1)
    chosen = (np.abs(centres[:, 0]) < 10) & np.isclose(np.abs(centres[:, 1]), 5.0)
    g = 5.0 - np.abs(centres[chosen, 2])
    analytic = np.pi / 8 * (np.exp(-g) + np.exp(-(10.0 - g)))
    error = curvature[chosen] - analytic
    assert np.abs(error).mean() < 0.015  # per mm; the peak on the edge is 0.39 / mm
    assert np.abs(error).max() < 0.1  # the first row of faces carries the edge itself


def test_curvature_cap_on_a_small_white_sphere():
    sphere = trimesh.creation.icosphere(4, 1.5)
    rule = dataclasses.replace(LIGHTNESS_RULE, smoothing=SmoothingRule(radius_mm=0.0))
    result = face_thickness(face_coloured(sphere, np.full((len(sphere.faces), 4), 255)), rule)
    # Uncapped: 1.02 mm (upper) to 1.2 mm (lower); cap 0.5 x radius = 0.75 mm.
    np.testing.assert_allclose(result.colour_layer_mm, 0.75, rtol=0.01)
    assert thickness_summary(result)["colour_layer"]["curvature_capped_faces"] == len(sphere.faces)


def test_face_colour_of_vertex_colours_is_the_corner_median():
    tet = trimesh.creation.icosphere(0, 10.0)
    corner = np.zeros((len(tet.faces), 3, 4), np.uint8)
    corner[:, :2] = [255, 255, 255, 200]
    corner[:, 2] = [0, 0, 0, 100]
    mesh = ColouredMesh(
        np.asarray(tet.vertices), np.asarray(tet.faces, np.int64), "vertex", corner_rgba=corner
    )
    stats = face_colour(mesh)
    np.testing.assert_allclose(stats.lab, np.tile(lab_of([255, 255, 255]), (len(tet.faces), 1)))
    np.testing.assert_allclose(stats.alpha, 200 / 255)
    # p90 of (0, 0, dE(white, black)) with linear interpolation: 0.8 of the way.
    white_black = colour.delta_E(lab_of([255, 255, 255]), lab_of([0, 0, 0]), method="CIE 2000")
    np.testing.assert_allclose(stats.spread_de00, 0.8 * white_black, rtol=1e-9)


def test_face_colour_of_a_texture_is_robust_to_a_minority():
    image = np.zeros((32, 32, 4), np.uint8)
    image[..., 3] = 255
    image[:, :16, :3] = [200, 30, 40]  # left half red
    image[:, 16:, :3] = [20, 60, 220]  # right half blue
    vertices = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)
    corner_uv = np.array(
        [
            [[0.05, 0.1], [0.4, 0.1], [0.05, 0.9]],  # wholly red
            [[0.6, 0.1], [0.95, 0.1], [0.95, 0.9]],  # wholly blue
            [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],  # 3/4 red, 1/4 blue
            [[0.05, 0.1], [0.4, 0.1], [0.05, 0.9]],
        ]
    )
    mesh = ColouredMesh(
        vertices,
        faces,
        "texture",
        corner_uv=corner_uv,
        face_material=np.zeros(4, np.int64),
        materials=(Material("halves", image=image, wrap=("clamp", "clamp")),),
    )
    stats = face_colour(mesh)
    red, blue = lab_of([200, 30, 40]), lab_of([20, 60, 220])
    np.testing.assert_allclose(stats.lab[[0, 2, 3]], np.tile(red, (3, 1)), atol=1e-9)
    np.testing.assert_allclose(stats.lab[1], blue, atol=1e-9)
    np.testing.assert_array_equal(stats.spread_de00[[0, 1, 3]], 0.0)
    # The p90 difference is the blue quarter's difference from red.
    red_blue = colour.delta_E(red, blue, method="CIE 2000")
    np.testing.assert_allclose(stats.spread_de00[2], red_blue, rtol=1e-9)
    # Samples follow the texels covered: half the image at 1 sample per texel or more.
    assert stats.n_samples[2] >= 0.5 * 32 * 32


# ---- TOML ---------------------------------------------------------------------------


def test_a_rule_file_with_every_default_value_is_the_default_rule(tmp_path):
    path = tmp_path / "rule.toml"
    path.write_text(
        'rule = "optical"\n'
        "[colour_layer]\nmin_mm = 0.3\nmax_mm = 3.0\ndelta_e = 1\nlightness_weight = 0.6\n"
        "neutral_weight = 0.2\ntransparency_weight = 0.2\nfull_chroma = 100\n"
        "[orientation]\nupper_factor = 1\nside_factor = 1\nlower_factor = 1\n"
        "upper_min_normal_z = 0.5\nlower_max_normal_z = -0.05\n"
        "[curvature]\nmax_depth_per_radius = 0.5\nradius_mm = 1\n"
        "[smoothing]\nradius_mm = 1\n"
        "[layers]\ncolour = [1]\nbacking_mm = [0.5]\n"
        "[split]\nmin_spread_de00 = 5\n"
    )
    assert load_rule(path) == DEFAULT_RULE


def test_a_lightness_rule_file_keeps_the_lightness_defaults(tmp_path):
    path = tmp_path / "rule.toml"
    path.write_text('rule = "lightness"\n[colour_layer]\nmin_mm = 0.4\n')
    rule = load_rule(path)
    assert rule.rule == "lightness"
    assert rule.colour_layer == dataclasses.replace(LIGHTNESS_RULE.colour_layer, min_mm=0.4)
    assert rule.orientation == LIGHTNESS_RULE.orientation


def test_the_shipped_example_rule_file_is_the_default_rule():
    shipped = Path(__file__).resolve().parents[2] / "data" / "thickness_rule.toml"
    assert load_rule(shipped) == DEFAULT_RULE


def test_a_partial_rule_file_changes_only_its_keys(tmp_path):
    path = tmp_path / "rule.toml"
    path.write_text("[colour_layer]\nmax_mm = 2.0\n[layers]\nbacking_mm = [0.4, 0.6]\n")
    rule = load_rule(path)
    assert rule.colour_layer == ColourLayerRule(max_mm=2.0)
    assert rule.rule == "optical"
    assert rule.layers == LayersRule(backing_mm=(0.4, 0.6))
    assert rule.orientation == DEFAULT_RULE.orientation
    assert rule.layers.n_layers == 3


@pytest.mark.parametrize(
    ("text", "key", "fix"),
    [
        ("[colour]\nmin_mm = 1\n", "[colour]", "[colour_layer]"),
        ("[colour_layer]\nminimum = 1\n", "colour_layer.minimum", "colour_layer.min_mm"),
        ("[colour_layer]\nmin_mm = 2.0\nmax_mm = 1.0\n", "colour_layer.min_mm", "min_mm <="),
        ("[colour_layer]\nmin_mm = -0.1\n", "colour_layer.min_mm", "min_mm = 0.3"),
        ('[colour_layer]\nmax_mm = "thick"\n', "colour_layer.max_mm", "max_mm = 3.0"),
        ("[smoothing]\niterations = 3\n", "smoothing.iterations", "radius_mm = 1.0"),
        ("[smoothing]\nradius_mm = -1\n", "smoothing.radius_mm", "radius_mm = 1.0"),
        ('rule = "colourful"\n', "rule must be", 'rule = "optical"'),
        ("[layers]\nbacking_mm = 0.5\n", "layers.backing_mm", "backing_mm = [0.5]"),
        ("[layers]\ncolour = [3]\n", "layers.colour", "colour = [1]"),
        ("[orientation]\nupper_min_normal_z = -0.5\n", "orientation.lower_max_normal_z", "-0.05"),
        ("[curvature]\nradius_mm = 0\n", "curvature.radius_mm", "radius_mm = 1.0"),
        ("smoothing = 3\n", "smoothing must be a table", "[smoothing]"),
        ("[colour_layer\nmin_mm = 1\n", "not valid TOML", "fix the syntax"),
    ],
)
def test_bad_rule_files_name_the_file_the_key_and_the_fix(tmp_path, text, key, fix):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError) as caught:
        load_rule(path)
    message = str(caught.value)
    assert str(path) in message
    assert key in message
    assert fix in caught.value.fix
    assert "\n" not in message


def test_a_missing_rule_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_rule(tmp_path / "nope.toml")


def test_a_rule_error_is_an_input_error_naming_the_key():
    from shellvox.thickness._rule import RuleError

    with pytest.raises(InputError) as caught:
        ColourLayerRule(min_mm=-1.0)
    error = caught.value
    assert isinstance(error, RuleError)
    assert error.key == error.path
    assert str(error) == str(InputError(error.key, error.problem, error.fix))
    assert "-1.0" in error.problem
