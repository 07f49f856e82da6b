"""--max-edge: splitting keeps the mesh closed, oriented, the same solid, and the same
colour at the same surface points (points located on the original with trimesh)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.errors import InputError
from shellvox.model import ColouredMesh, Material, edge_report, face_areas, signed_volume
from shellvox.thickness import (
    DEFAULT_RULE,
    SplitRule,
    ThicknessRule,
    face_colour,
    split_faces,
    split_for_thickness,
)


def _edge_lengths(mesh: ColouredMesh) -> np.ndarray:
    corners = mesh.triangles
    return np.linalg.norm(corners - np.roll(corners, -1, axis=1), axis=2)


def _coloured(kind: str, shape: trimesh.Trimesh, seed: int = 0) -> ColouredMesh:
    rng = np.random.default_rng(seed)
    n = len(shape.faces)
    vertices = np.asarray(shape.vertices, float)
    faces = np.asarray(shape.faces, np.int64)
    if kind == "texture":
        images = (
            Material("a", image=rng.integers(0, 256, (16, 16, 4)).astype(np.uint8)),
            Material(
                "b",
                image=rng.integers(0, 256, (8, 32, 4)).astype(np.uint8),
                filter="nearest",
                wrap=("mirror", "clamp"),
            ),
        )
        return ColouredMesh(
            vertices,
            faces,
            "texture",
            corner_uv=rng.uniform(-0.5, 1.5, (n, 3, 2)),
            face_material=rng.integers(0, 2, n),
            materials=images,
        )
    if kind == "vertex":
        return ColouredMesh(
            vertices, faces, "vertex", corner_rgba=rng.integers(0, 256, (n, 3, 4)).astype(np.uint8)
        )
    return ColouredMesh(
        vertices, faces, "face", face_rgba=rng.integers(0, 256, (n, 4)).astype(np.uint8)
    )


SHAPES = {
    "box": lambda: trimesh.creation.box((12.0, 7.0, 5.0)),
    "sphere": lambda: trimesh.creation.icosphere(1, 8.0),
    "hull": lambda: trimesh.convex.convex_hull(
        np.random.default_rng(4).normal(size=(40, 3)) * [9.0, 5.0, 3.0]
    ),
}


@pytest.mark.parametrize("shape", sorted(SHAPES))
@pytest.mark.parametrize("kind", ["texture", "vertex", "face"])
def test_split_keeps_the_solid_closed_oriented_and_short_edged(shape, kind):
    mesh = _coloured(kind, SHAPES[shape]())
    split = split_faces(mesh, 1.5).mesh
    report = edge_report(split.faces)
    assert report.closed and report.oriented
    assert len(split.faces) > len(mesh.faces)
    assert _edge_lengths(split).max() <= 1.5
    np.testing.assert_allclose(
        signed_volume(split.vertices, split.faces),
        signed_volume(mesh.vertices, mesh.faces),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        face_areas(split.vertices, split.faces).sum(),
        face_areas(mesh.vertices, mesh.faces).sum(),
        rtol=1e-12,
    )


@pytest.mark.parametrize("kind", ["texture", "vertex", "face"])
def test_split_keeps_the_colour_at_every_surface_point(kind):
    shape = SHAPES["hull"]()
    mesh = _coloured(kind, shape, seed=7)
    split = split_faces(mesh, 2.0).mesh
    rng = np.random.default_rng(11)
    child = rng.integers(0, len(split.faces), 4000)
    weights = rng.dirichlet(np.ones(3), len(child))
    points = np.einsum("nc,nck->nk", weights, split.triangles[child])
    # Locate each point on the original surface independently of the split's bookkeeping.
    _, _, parent = trimesh.proximity.closest_point(shape, points)
    parent_weights = trimesh.triangles.points_to_barycentric(shape.triangles[parent], points)
    before = mesh.colour_at(np.asarray(parent, np.int64), parent_weights)
    after = split.colour_at(child, weights)
    if kind == "vertex":  # new corners are re-quantised to uint8: one sRGB step at most
        assert np.abs(before.astype(int) - after.astype(int)).max() <= 1
    else:
        np.testing.assert_array_equal(after, before)


def test_only_the_chosen_faces_and_their_shared_edges_are_split():
    mesh = _coloured("face", trimesh.creation.box((10.0, 10.0, 10.0)))
    chosen = np.zeros(12, bool)
    chosen[0] = True
    result = split_faces(mesh, 1.0, where=chosen)
    lengths = _edge_lengths(result.mesh)
    assert lengths[result.parent == 0].max() <= 1.0
    assert lengths[result.parent != 0].max() > 1.0  # the others keep long edges
    report = edge_report(result.mesh.faces)
    assert report.closed and report.oriented
    # Faces that share no edge with face 0 are untouched.
    shares = np.array([len(set(mesh.faces[f]) & set(mesh.faces[0])) == 2 for f in range(12)])
    for f in np.flatnonzero(~shares & ~chosen):
        assert np.count_nonzero(result.parent == f) == 1


def test_split_for_thickness_splits_only_faces_of_mixed_colour():
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    image = np.zeros((2, 2, 4), np.uint8)
    image[..., 3] = 255
    image[:, 0, :3] = 255  # left column white, right column black
    n = len(box.faces)
    corner_uv = np.tile([[0.1, 0.1], [0.2, 0.1], [0.1, 0.2]], (n, 1, 1))  # white only
    corner_uv[3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]  # half white, half black
    mesh = ColouredMesh(
        np.asarray(box.vertices),
        np.asarray(box.faces, np.int64),
        "texture",
        corner_uv=corner_uv,
        face_material=np.zeros(n, np.int64),
        materials=(Material("two", image=image, wrap=("clamp", "clamp")),),
    )
    spread = face_colour(mesh).spread_de00
    assert spread[3] > DEFAULT_RULE.split.min_spread_de00
    assert np.all(np.delete(spread, 3) == 0)
    split = split_for_thickness(mesh, DEFAULT_RULE, 2.0)
    assert len(split.faces) > n
    assert edge_report(split.faces).oriented
    # With a threshold above the spread nothing is split: the same mesh comes back.
    high = ThicknessRule(split=SplitRule(min_spread_de00=float(spread.max()) + 1))
    assert split_for_thickness(mesh, high, 2.0) is mesh


def test_too_many_faces_is_refused_naming_max_edge():
    mesh = _coloured("face", trimesh.creation.box((10.0, 10.0, 10.0)))
    with pytest.raises(InputError, match="max_edge_mm="):
        split_faces(mesh, 0.01, max_faces=10_000)


def test_bad_max_edge_is_a_value_error():
    mesh = _coloured("face", trimesh.creation.box((10.0, 10.0, 10.0)))
    with pytest.raises(ValueError, match="max_edge_mm"):
        split_faces(mesh, 0.0)
