"""Compiled voxel colours against ColouredMesh.colour_at (the numpy reference), bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.model import ColouredMesh, Material
from shellvox.voxel.colour import voxel_colours
from shellvox.voxel.geometry import SurfaceIndex, on_faces


def _mesh(kind: str, wrap: str = "repeat", filter_mode: str = "linear") -> ColouredMesh:
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    vertices, faces = sphere.vertices, sphere.faces.astype(np.int64)
    rng = np.random.default_rng(7)
    n = len(faces)
    if kind == "face":
        rgba = rng.integers(0, 256, (n, 4), np.uint8)
        return ColouredMesh(vertices, faces, "face", face_rgba=rgba)
    if kind == "vertex":
        rgba = rng.integers(0, 256, (n, 3, 4)).astype(np.uint8)
        return ColouredMesh(vertices, faces, "vertex", corner_rgba=rgba)
    if kind == "none":
        return ColouredMesh(vertices, faces)
    images = [rng.integers(0, 256, (13, 21, 4)).astype(np.uint8), None]
    materials = tuple(
        Material(f"m{i}", factor=np.array([0.9, 0.7, 1.0, 0.8]), image=image,
                 wrap=(wrap, wrap), filter=filter_mode)  # type: ignore[arg-type]
        for i, image in enumerate(images)
    )  # fmt: skip
    uv = rng.uniform(-1.5, 2.5, (n, 3, 2))  # outside [0, 1]: the wrap rule matters
    return ColouredMesh(
        vertices, faces, "texture", corner_uv=uv, face_material=rng.integers(0, 2, n),
        materials=materials,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("kind", "wrap", "filter_mode"),
    [
        ("face", "repeat", "linear"),
        ("vertex", "repeat", "linear"),
        ("none", "repeat", "linear"),
        ("texture", "repeat", "linear"),
        ("texture", "clamp", "linear"),
        ("texture", "mirror", "nearest"),
        ("texture", "repeat", "nearest"),
    ],
)
def test_same_colours_as_colour_at(kind: str, wrap: str, filter_mode: str) -> None:
    mesh = _mesh(kind, wrap, filter_mode)
    rng = np.random.default_rng(1)
    points = rng.uniform(-4, 4, (20_000, 3))
    surface = SurfaceIndex.build(mesh.vertices, mesh.faces)
    faces = rng.integers(0, mesh.n_faces, len(points))  # any face: every Voronoi region
    expected = mesh.colour_at(faces, on_faces(surface, points, faces).barycentric)
    got = voxel_colours(points, faces, mesh.vertices, mesh.faces, mesh.surface_colour())
    np.testing.assert_array_equal(got, expected)
