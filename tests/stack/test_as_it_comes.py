"""Models as they come build as they are: checked against libigl and manifold3d, not shellvox.

- an open model (the teapot): the built solid against libigl's winding number (w >= 1/2);
- two coloured boxes pushed into each other: the layers against the distance to
  manifold3d's union of the two, and no layer around the faces buried in the overlap.
"""

from __future__ import annotations

import json

import igl
import manifold3d
import numpy as np
import pytest
import tifffile
import trimesh
from conftest import shared_path

import shellvox

pytestmark = pytest.mark.slow


def _voxel_centres(out):
    grid = json.loads((out / "manifest.json").read_text())["grid"]
    shape = tuple(grid["shape_zyx"])
    index = np.stack(np.meshgrid(*map(np.arange, shape), indexing="ij"), -1).reshape(-1, 3)
    origin, voxel = np.asarray(grid["origin_mm"]), np.asarray(grid["voxel_size_mm"])
    return origin + index[:, ::-1] * voxel, shape, voxel


def _build(path, out, load=None, **options):
    defaults = {"voxel_size_mm": 0.4, "materials": None, "formats": ("tiff",)}
    settings = shellvox.BuildOptions(**{**defaults, **options})
    with pytest.warns(shellvox.ShellvoxWarning, match="read as it comes"):
        shellvox.build(path, out, settings, load=load, progress=False)
    return tifffile.imread(out / "layers.tif")


def test_the_open_teapot_builds_the_solid_of_its_winding_number(tmp_path):
    path = shared_path("teapot/teapot.obj")
    load = shellvox.LoadOptions(size_mm=60.0)
    layers = _build(path, tmp_path / "out", load=load)
    mesh = shellvox.load_model(path, load, check="report")
    assert shellvox.model.edge_report(mesh.faces).boundary.size  # open as it comes
    points, shape, voxel = _voxel_centres(tmp_path / "out")
    winding = igl.fast_winding_number(mesh.vertices, mesh.faces, points).reshape(shape)
    squared, _, _ = igl.point_mesh_squared_distance(points, mesh.vertices, mesh.faces)
    far = np.sqrt(squared).reshape(shape) > 2 * np.linalg.norm(voxel)
    agree = (layers > 0) == (winding >= 0.5)
    assert (winding[far] >= 0.5).sum() > 1000
    assert agree[far].mean() >= 0.995


def _boxes(path):
    """Two boxes pushed into each other, one red and one blue, written as a PLY."""
    a = trimesh.creation.box(extents=(12, 8, 8))
    b = trimesh.creation.box(extents=(8, 12, 8))
    b.apply_translation((4, 3, 2))
    a.visual.face_colors = (200, 30, 30, 255)
    b.visual.face_colors = (30, 30, 200, 255)
    trimesh.util.concatenate([a, b]).export(path)
    union = manifold3d.Manifold.cube((12, 8, 8), center=True) + manifold3d.Manifold.cube(
        (8, 12, 8), center=True
    ).translate((4, 3, 2))
    mesh = union.to_mesh()
    return np.asarray(mesh.vert_properties[:, :3], np.float64), np.asarray(mesh.tri_verts)


def test_overlapping_boxes_layer_by_the_distance_to_their_union(tmp_path):
    path = tmp_path / "boxes.ply"
    vertices, faces = _boxes(path)
    thickness = (0.8, 0.8)
    depth = np.cumsum(thickness)  # each layer's inner boundary (mm)
    layers = _build(path, tmp_path / "out", thickness_mm=thickness, voxel_size_mm=0.2)
    points, shape, voxel = _voxel_centres(tmp_path / "out")
    squared, _, _ = igl.point_mesh_squared_distance(points, vertices, faces)
    distance = np.sqrt(squared).reshape(shape)
    inside = (igl.fast_winding_number(vertices, faces, points) >= 0.5).reshape(shape)
    expected = np.where(inside, 1 + (distance >= depth[0]) + (distance >= depth[1]), 0)
    diagonal = np.linalg.norm(voxel)
    clear = (np.abs(distance - depth[0]) > diagonal) & (np.abs(distance - depth[1]) > diagonal)
    clear &= distance > diagonal
    assert (layers[clear] == expected[clear]).mean() >= 0.999
    # the faces buried in the overlap make no layer: deep inside it, all core
    overlap = inside & (distance > depth[1] + diagonal)
    assert overlap.sum() > 1000
    assert (layers[overlap] == 3).all()


def test_shell_meshes_of_a_model_as_it_comes_are_refused_in_one_line(tmp_path):
    path = tmp_path / "boxes.ply"
    _boxes(path)
    options = shellvox.BuildOptions(voxel_size_mm=0.5, materials=None, shell_meshes=True)
    with (
        pytest.warns(shellvox.ShellvoxWarning, match="read as it comes"),
        pytest.raises(shellvox.InputError, match="shell_meshes") as refused,
    ):
        shellvox.build(path, tmp_path / "out", options, progress=False)
    assert "--shell-meshes" in refused.value.words("cli")
    assert not (tmp_path / "out" / "layers.tif").exists()


def test_layers_from_offset_shells_of_a_model_as_it_comes_are_refused(tmp_path):
    path = tmp_path / "boxes.ply"
    _boxes(path)
    options = shellvox.BuildOptions(voxel_size_mm=0.5, materials=None, layer_rule="shells")
    with (
        pytest.warns(shellvox.ShellvoxWarning, match="read as it comes"),
        pytest.raises(shellvox.InputError, match="layer_rule") as refused,
    ):
        shellvox.build(path, tmp_path / "out", options, progress=False)
    assert "--layers" in refused.value.words("cli")
