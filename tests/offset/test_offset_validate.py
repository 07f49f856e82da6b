"""Argument checks of the public offset API."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.offset import offset_shells, shell_report


@pytest.fixture
def box() -> trimesh.Trimesh:
    return trimesh.creation.box((10.0, 10.0, 10.0))


def test_unknown_method_is_rejected(box):
    with pytest.raises(ValueError, match=r"method must be one of .* got 'exact'"):
        offset_shells(box.vertices, box.faces, [0.5], method="exact")


@pytest.mark.parametrize(
    ("thickness", "match"),
    [
        ([[0.5, 0.5]], r"thickness must have shape \(K,\) or \(K, 12\).*got \(1, 2\)"),
        (np.zeros((1, 2, 3)), r"thickness must have shape .* got \(1, 2, 3\)"),
        ([0.5, np.nan], r"thickness must be finite, got 12 NaN/inf"),
        ([0.5, -1.0], r"thickness must be > 0 mm, got minimum -1.0"),
        ([0.0], r"thickness must be > 0 mm, got minimum 0.0"),
    ],
)
def test_bad_thickness_is_rejected(box, thickness, match):
    with pytest.raises(ValueError, match=match):
        offset_shells(box.vertices, box.faces, thickness, method="robust")


def test_bad_mesh_is_rejected(box):
    with pytest.raises(ValueError, match=r"vertices must have shape \(V, 3\).*got \(8, 2\)"):
        offset_shells(box.vertices[:, :2], box.faces, [0.5], method="robust")
    v = np.array(box.vertices)
    v[0, 0] = np.inf
    with pytest.raises(ValueError, match=r"vertices must be finite, got 1 NaN/inf"):
        offset_shells(v, box.faces, [0.5], method="robust")
    with pytest.raises(ValueError, match=r"faces must hold integers, got dtype float64"):
        offset_shells(box.vertices, box.faces.astype(float), [0.5], method="robust")
    with pytest.raises(ValueError, match=r"faces must index \[0, 8\), got range \[0, 8\]"):
        offset_shells(box.vertices, np.where(box.faces == 7, 8, box.faces), [0.5], method="robust")


def test_open_mesh_is_rejected(box):
    with pytest.raises(ValueError, match=r"faces must form a closed surface, got 3 boundary"):
        offset_shells(box.vertices, box.faces[:-1], [0.5], method="robust")


def test_report_checks_shell_count(box):
    shells = offset_shells(box.vertices, box.faces, [0.5], method="robust")
    with pytest.raises(ValueError, match=r"shells must hold one shell per layer \(2\), got 1"):
        shell_report(box.vertices, box.faces, [0.5, 0.5], shells)
