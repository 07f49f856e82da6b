"""Real meshes at the J750 grid (slow): layers vs closest points, colour vs nearest colour."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile
import trimesh

from shellvox.config import BuildConfig
from shellvox.loading import load_model
from shellvox.printer import load_profile
from shellvox.stack import build_stack


@pytest.mark.slow
def test_pyramid_at_j750(shared_mesh, tmp_path):
    import colour

    mesh = load_model(shared_mesh("3mf/pyramid_vertexcolor.3mf"))
    config = BuildConfig(voxel_mm=load_profile("j750").voxel_mm, printer="j750", slab_mb=128)
    manifest = build_stack(mesh, config, tmp_path, progress=False)
    assert manifest["diagnostics"]["unbalanced_rows"] == 0
    assert manifest["diagnostics"]["nesting_violations"] == 0
    layers = tifffile.imread(tmp_path / "layers.tif")
    grid = manifest["grid"]
    voxel = np.asarray(grid["voxel_size_mm"])
    rng = np.random.default_rng(0)
    chosen = np.concatenate(
        [rng.choice(np.flatnonzero(layers.ravel() == k), 4000, replace=False) for k in (1, 2, 3)]
    )
    zyx = np.stack(np.unravel_index(chosen, layers.shape), axis=1)
    centres = np.asarray(grid["origin_mm"]) + zyx[:, ::-1] * voxel
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    closest, distance, face = trimesh.proximity.closest_point(tm, centres)
    # a convex solid: every sampled voxel is inside, so depth = distance
    predicted = 1 + (distance[:, None] > np.array([0.5, 1.0])[None, :]).sum(axis=1)
    clear = np.abs(distance[:, None] - np.array([0.0, 0.5, 1.0])).min(axis=1) > np.linalg.norm(
        voxel
    )
    got = layers.ravel()[chosen]
    assert np.mean((got == predicted)[clear]) >= 0.999

    rgb = tifffile.imread(tmp_path / "colour.tif")[tuple(zyx[got == 1].T)]
    bary = trimesh.triangles.points_to_barycentric(
        mesh.vertices[mesh.faces[face[got == 1]]], closest[got == 1]
    )
    bary = np.clip(bary, 0.0, 1.0)
    exact = mesh.colour_at(face[got == 1], bary / bary.sum(axis=1)[:, None])[:, :3]

    def lab(values):
        return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(values / 255.0))

    delta = colour.delta_E(lab(rgb), lab(exact), method="CIE 2000")
    assert np.median(delta) <= 1.0
    assert np.percentile(delta, 99) <= 5.0
