"""The colour report's optical model against its closed form, on a slab-split box."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import trimesh

from voxel.colour.report import ColourReport, colour_regions, delta_e_2000, sample_surface
from voxel.grid import GridSpec


def _box_case(depth_mm, optical_mm, voxel=0.05):
    box = trimesh.creation.box((4.0, 4.0, 4.0))
    grid = GridSpec.from_bounds([-2, -2, -2], [2, 2, 2], (voxel,) * 3, margin_mm=0.2)
    centres = grid.index_to_world(np.indices(grid.shape_zyx).reshape(3, -1).T)
    inside = np.all(np.abs(centres) < 2, axis=1)
    depth = 2 - np.abs(centres).max(axis=1)  # distance to the box surface inside
    materials = np.where(inside, np.where(depth < depth_mm, 1, 2), 0).astype(np.uint8)
    samples = sample_surface(
        box.vertices,
        box.faces.astype(np.int64),
        lambda f, b: np.tile(np.array([200, 40, 40, 255], np.uint8), (len(f), 1)),
        400,
        seed=3,
    )
    # keep samples away from edges, where the inward ray leaves the face's own slab
    tangential = np.abs(samples.points) * (1 - np.abs(samples.normals))
    keep = tangential.max(axis=1) < 1.5
    samples = type(samples)(
        *(a[keep] for a in (samples.points, samples.normals, samples.face_ids, samples.target_rgba))
    )
    display = np.array([[0, 0, 0], [255, 0, 0], [255, 255, 255]], np.uint8)
    return grid, materials.reshape(grid.shape_zyx), samples, display


@pytest.mark.parametrize("slab", [7, 1000])
def test_two_layer_prediction_matches_closed_form(slab):
    depth_mm, optical_mm = 0.3, 0.25
    grid, materials, samples, display = _box_case(depth_mm, optical_mm)
    report = ColourReport(samples, grid, display, optical_depth_mm=optical_mm)
    for z in range(0, grid.shape_zyx[0], slab):
        report.add_slab(z, materials[z : z + slab])
    predicted = report.predicted_srgb()
    # closed form: share of the top material = int_0^D e^{-s/L} / int_0^{4L} e^{-s/L}
    share = (1 - np.exp(-depth_mm / optical_mm)) / (1 - np.exp(-4.0))
    red = colour.cctf_decoding(np.array([1.0, 0.0, 0.0]), "sRGB")
    white = np.ones(3)
    expected = colour.cctf_encoding(share * red + (1 - share) * white, "sRGB")
    # voxel quantisation of the layer boundary: within half a voxel of depth
    assert np.abs(predicted - expected).max() < 0.04
    assert report.result()["samples_seen"] == len(samples.points)


def test_uniform_material_predicts_its_display_colour():
    grid, materials, samples, display = _box_case(10.0, 0.25)
    report = ColourReport(samples, grid, display, optical_depth_mm=0.25)
    report.add_slab(0, materials)
    assert np.allclose(report.predicted_srgb(), [1.0, 0.0, 0.0], atol=1e-9)
    result = report.result()
    expected = delta_e_2000(np.array([[1.0, 0, 0]]), np.array([[200 / 255, 40 / 255, 40 / 255]]))
    assert result["ciede2000"]["median"] == pytest.approx(float(expected[0]), abs=1e-6)  # rounded


def test_regions_name_lightness_and_hue():
    names = colour_regions(np.array([[250, 250, 250], [20, 20, 20], [220, 30, 30]], np.uint8))
    assert names[0] == "light neutral" and names[1] == "dark neutral"
    assert names[2].endswith("red")


def test_layer_model_limits_and_thickness_effect():
    from voxel.colour.report import layer_model_srgb, thickness_effect

    ideal = colour.cctf_decoding(np.array([[0.8, 0.1, 0.1], [0.1, 0.1, 0.8]]), "sRGB")
    backing = np.ones(3)
    deep = layer_model_srgb(ideal, backing, np.array([1.0, 2.0]), 0.25)  # >= 4 L
    assert np.allclose(deep, [[0.8, 0.1, 0.1], [0.1, 0.1, 0.8]], atol=1e-9)
    none = layer_model_srgb(ideal, backing, np.zeros(2), 0.25)
    assert np.allclose(none, 1.0)
    target = np.array([[204, 26, 26, 255], [26, 26, 204, 255]], np.uint8)
    effect = thickness_effect(target, ideal, backing, np.array([1.0, 1.0]), 0.1, 0.25)
    # a deep layer shows the separation's own mix; a thin one lets the white through
    assert effect["adaptive"]["max"] == pytest.approx(effect["gamut"]["max"], abs=1e-6)
    assert effect["constant"]["median"] > effect["adaptive"]["median"] + 5
