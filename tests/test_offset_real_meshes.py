"""Robust shells of real meshes from ../shared/meshes: closed, oriented, nested, equidistant."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from offset import offset_shells, shell_report


def _load(path, size_mm: float) -> trimesh.Trimesh:
    raw = trimesh.load(path, force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    mesh.apply_scale(size_mm / mesh.extents.max())
    return mesh


@pytest.mark.slow
def test_bunny_shells_are_valid_nested_and_equidistant(shared_mesh):
    bunny = _load(shared_mesh("bunny/bunny.obj"), 50.0)
    thickness = [0.5, 1.0]  # depths 0.5 and 1.5 mm
    shells = offset_shells(bunny.vertices, bunny.faces, thickness)
    report = shell_report(bunny.vertices, bunny.faces, thickness, shells, baselines=False,
                          n_samples=2000)
    for layer in report["layers"]:
        shell = layer["shell"]
        assert shell["closed"]
        assert shell["oriented"]
        assert shell["self_intersections"] == 0
        assert shell["nested"]
        assert shell["equidistance"]["error_pct"]["p99"] <= 2.0
        # Never deeper than asked (inscribed polytopes), at most a few % shallower.
        assert shell["equidistance"]["error_pct"]["max"] <= 5.0
        # Area-weighted, most of the shell lies over face interiors, exactly at D.
        assert shell["equidistance"]["error_pct"]["p50"] <= 1e-6
    # Independent check on shell vertices: none deeper than D beyond the pieces' overlap
    # allowance (corners grow by at most 1e-2 D, so 5e-5 D deeper).
    rng = np.random.default_rng(0)
    some = rng.choice(len(shells[1].vertices), size=3000, replace=False)
    dist = trimesh.proximity.closest_point(bunny, shells[1].vertices[some])[1]
    assert np.all(dist <= 1.5 * (1 + 1e-4))
    assert np.all(dist >= 1.5 * (1 - 0.05))
