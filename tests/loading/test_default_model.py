"""The bundled default model is what its generator makes, and loads as a textured solid."""

from __future__ import annotations

import filecmp
import importlib.util
from pathlib import Path

import numpy as np

from shellvox.loading import load_model

DATA = Path(__file__).resolve().parents[2] / "data"


def test_default_model_is_reproducible(tmp_path):
    spec = importlib.util.spec_from_file_location("make", DATA / "make_colour_target.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.write(tmp_path)
    for name in ("colour_target.obj", "colour_target.mtl"):
        assert filecmp.cmp(tmp_path / name, DATA / "colour_target" / name, shallow=False)


def test_default_model_is_a_closed_textured_block():
    mesh = load_model(DATA / "colour_target" / "colour_target.obj")
    assert mesh.colour_kind == "texture"
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [24.0, 16.0, 6.0], atol=1e-6)
    # Rounded box volume: box minus edge and corner material, analytically.
    r, (a, b, c) = 1.5, (24.0, 16.0, 6.0)
    edges = 4 * (a + b + c - 6 * r) * r * r * (1 - np.pi / 4)
    corners = 8 * r**3 - 4 / 3 * np.pi * r**3
    exact = a * b * c - edges - corners
    from shellvox.model import signed_volume

    # The mesh is a polygonal approximation of the rounding (5 segments per quarter).
    assert abs(signed_volume(mesh.vertices, mesh.faces) - exact) < 0.01 * exact
    colours = mesh.colour_at(np.arange(len(mesh.faces)), np.full((len(mesh.faces), 3), 1 / 3))
    assert len(np.unique(colours, axis=0)) > 20
