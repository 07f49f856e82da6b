"""SoftProof.at: Shepard interpolation of the samples facing the query's side.

Checked against a slow reference written from the module's rule (a loop over the queries,
every sample's distance by numpy), and on the cases that decide what a picture shows: a
sample's own value at the sample, a thin wall's two faces apart, nothing far from the
surface.
"""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.voxel.colour import SoftProof
from shellvox.voxel.colour._proof import NEIGHBOURS, REACH_SPACINGS, SAME_SIDE, _demo_proof


def _proof(points, normals, lab, de, spacing):
    """A proof whose target, aim and prediction are `lab` and whose errors are `de`."""
    return SoftProof(
        points_mm=np.asarray(points, float),
        normals=np.asarray(normals, float),
        target_lab=lab,
        aim_lab=lab,
        predicted_lab=lab,
        total_de=de,
        gamut_de=de,
        reproduction_de=de,
        spacing_mm=spacing,
        white_xy=np.array([0.3457, 0.3585]),
        optics="assumed",
    )


def _sphere(count, seed):
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(count, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return 5.0 * normals, normals, rng


def test_at_matches_a_slow_reference():
    points, normals, rng = _sphere(3000, 1)
    lab = rng.uniform(0, 100, (len(points), 3))
    de = rng.uniform(0, 10, len(points))
    de[::7] = np.nan  # no prediction there
    spacing = float(np.sqrt(4 * np.pi * 25.0 / len(points)))
    proof = _proof(points, normals, lab, de, spacing)
    queries, query_normals, _ = _sphere(400, 2)
    queries *= 1.0 + rng.uniform(-0.01, 0.01, (len(queries), 1))  # near the surface
    got = proof.at(queries, query_normals)
    for q, (point, normal) in enumerate(zip(queries, query_normals, strict=True)):
        distance = np.linalg.norm(points - point, axis=1)
        nearest = np.argsort(distance, kind="stable")[:NEIGHBOURS]
        keep = nearest[
            (distance[nearest] <= REACH_SPACINGS * spacing)
            & (normals[nearest] @ normal > SAME_SIDE)
        ]
        weight = 1.0 / np.maximum(distance[keep], 1e-6) ** 2
        finite = np.isfinite(de[keep])
        expected_de = (weight[finite] * de[keep][finite]).sum() / weight[finite].sum()
        expected_lab = (weight[:, None] * lab[keep]).sum(axis=0) / weight.sum()
        assert got.total_de[q] == pytest.approx(expected_de, rel=1e-9)
        assert got.predicted_lab[q] == pytest.approx(expected_lab, rel=1e-9)


def test_a_sample_keeps_its_value_and_a_thin_walls_faces_stay_apart():
    # two faces of a wall 0.2 mm thick, samples 0.25 mm apart, different colours
    grid = np.stack(np.meshgrid(np.arange(-2, 2.01, 0.25), np.arange(-2, 2.01, 0.25)), -1)
    flat = grid.reshape(-1, 2)
    front = np.column_stack([flat, np.full(len(flat), 0.1)])
    back = np.column_stack([flat, np.full(len(flat), -0.1)])
    points = np.concatenate([front, back])
    normals = np.concatenate(
        [np.tile([0, 0, 1.0], (len(flat), 1)), np.tile([0, 0, -1.0], (len(flat), 1))]
    )
    lab = np.concatenate(
        [np.tile([80.0, 0, 0], (len(flat), 1)), np.tile([20.0, 0, 0], (len(flat), 1))]
    )
    lab[5] = [60.0, 10.0, -10.0]
    de = np.zeros(len(points))
    proof = _proof(points, normals, lab, de, 0.25)
    at_sample = proof.at(points[5:6], normals[5:6])
    assert at_sample.predicted_lab[0] == pytest.approx(lab[5], abs=1e-6)
    between = np.array([[0.1, 0.1, 0.1], [0.1, 0.1, -0.1]])
    sides = proof.at(between, np.array([[0, 0, 1.0], [0, 0, -1.0]]))
    assert sides.predicted_lab[0, 0] == pytest.approx(80.0)
    assert sides.predicted_lab[1, 0] == pytest.approx(20.0)


def test_far_from_the_samples_there_is_no_prediction():
    proof = _demo_proof()
    far = proof.at([[0.0, 0.0, 1.0], [0.0, 0.0, 0.01]], [0.0, 0.0, 1.0])
    assert np.isnan(far.predicted_lab[0]).all() and np.isnan(far.total_de[0])
    assert np.isfinite(far.predicted_lab[1]).all()
    assert far.srgb("predicted")[0].tolist() == [160, 160, 160]
    behind = proof.at([[0.0, 0.0, 0.01]], [0.0, 0.0, -1.0])  # no sample faces that way
    assert np.isnan(behind.total_de[0])
