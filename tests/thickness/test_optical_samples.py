"""The optical rule serves every colour a face covers, not only its robust colour."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from builders import j750_layer_model

from shellvox.model import ColouredMesh
from shellvox.thickness import DEFAULT_RULE, face_colour, face_samples, optical_thickness
from shellvox.voxel.colour import depth_effect

GREY = np.array([128, 128, 128, 255], np.uint8)
YELLOW = np.array([230, 200, 20, 255], np.uint8)


def _settling(model, rgba):
    layer = DEFAULT_RULE.colour_layer
    found = model.settle(
        model.shares(np.asarray(rgba, np.uint8)), delta_e=layer.delta_e, max_mm=layer.max_mm
    )
    return found.depth_mm


def test_a_face_is_as_deep_as_its_deepest_corner_needs():
    box = trimesh.creation.box((20.0, 20.0, 10.0))
    corners = np.tile(GREY, (len(box.vertices), 1))
    corners[0] = YELLOW
    faces = np.asarray(box.faces, np.int64)
    mesh = ColouredMesh(
        np.asarray(box.vertices), faces, "vertex", corner_rgba=corners[faces], source="box"
    )
    model = j750_layer_model()
    grey_mm, yellow_mm = _settling(model, np.stack([GREY, YELLOW]))
    assert yellow_mm > grey_mm + 0.1  # the case only means something if they differ
    found = optical_thickness(face_colour(mesh), model, DEFAULT_RULE, face_samples(mesh))
    touches = (faces == 0).any(axis=1)
    np.testing.assert_allclose(found.thickness_mm[touches], yellow_mm)
    np.testing.assert_allclose(found.thickness_mm[~touches], grey_mm)
    np.testing.assert_allclose(found.robust_mm, grey_mm)  # two grey corners of three
    np.testing.assert_array_equal(found.deepest_rgba[touches], np.tile(YELLOW, (touches.sum(), 1)))
    without = optical_thickness(face_colour(mesh), model, DEFAULT_RULE)
    np.testing.assert_allclose(without.thickness_mm, grey_mm)


def test_same_coverage_constant_depth_covers_that_share_and_no_less_depth_does():
    model = j750_layer_model()
    rng = np.random.default_rng(3)
    rgba = np.concatenate([rng.integers(0, 256, (400, 3)), np.full((400, 1), 255)], axis=1)
    shares = model.shares(rgba.astype(np.uint8))
    depth = np.full(len(shares), 0.6)
    effect = depth_effect(model, shares, depth, delta_e=1.0, max_mm=3.0)
    same = effect["for_same_coverage"]
    covered = same["covered_share"]
    constant = same["constant_mm"]
    assert covered == effect["adaptive"]["covered_share"]
    reached = model.distance_at(shares, np.full(len(shares), constant)) <= 1.0
    assert reached.mean() >= covered - 1e-9
    short = model.distance_at(shares, np.full(len(shares), constant * 0.98)) <= 1.0
    assert short.mean() < covered
    assert same["constant_over_adaptive"] == pytest.approx(constant / 0.6, abs=2e-6)
    assert constant <= 0.6 + 1e-6  # one depth everywhere: no constant depth beats itself
