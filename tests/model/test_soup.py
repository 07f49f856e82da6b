"""A mesh as it comes: holes, parts, overlaps, buried faces and orientation, against
trimesh's edges and parts, manifold3d's intersections and libigl's exact winding numbers."""

from __future__ import annotations

import igl
import manifold3d
import numpy as np
import pytest
import trimesh
from conftest import shared_path

from shellvox.loading import load_model
from shellvox.model import ColouredMesh, inspect_soup, prepare
from shellvox.model._soup import SIDE_OFFSET


def _mesh(*parts: trimesh.Trimesh) -> ColouredMesh:
    """The parts as one mesh, each with its own vertices, merged by position."""
    starts = np.cumsum([0] + [len(p.vertices) for p in parts])
    vertices = np.concatenate([p.vertices for p in parts])
    faces = np.concatenate([p.faces + s for p, s in zip(parts, starts, strict=False)])
    return prepare(ColouredMesh(vertices, faces, source="soup"), check="report")


def _box(size=2.0, at=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(size,) * 3).apply_translation(at)


def _solid(part: trimesh.Trimesh) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh(
            vert_properties=np.asarray(part.vertices, np.float32),
            tri_verts=np.asarray(part.faces, np.uint32),
        )
    )


def test_open_teapot_edges_and_parts_match_trimesh():
    path = shared_path("teapot/teapot.obj")
    report = inspect_soup(load_model(path, check="report"))
    reference = trimesh.load(path, force="mesh")  # merges vertices by position
    single = trimesh.grouping.group_rows(np.sort(reference.edges, axis=1), require_count=1)
    assert report.boundary_edges == len(single) > 0
    assert len(report.part_faces) == len(reference.split(only_watertight=False))
    assert report.part_faces.sum() == len(reference.faces)
    # The holes are the closed loops of trimesh's outline of the boundary edges.
    assert report.hole_edges.sum() == len(single)
    assert len(report.hole_edges) == len(reference.outline().entities)
    assert not report.part_closed.any()


@pytest.mark.parametrize(
    "offset",
    [
        (1.0, 1.0, 1.0),
        (1.9, 0.0, 0.0),
        (2.0, 0.5, 0.0),
        (0.5, 2.5, 0.0),
        (1.9, 1.9, 1.9),
        (3.0, 3.0, 3.0),
    ],
)
def test_overlapping_parts_are_those_manifold3d_intersects(offset):
    first, second = _box(), _box(at=offset)
    report = inspect_soup(_mesh(first, second))
    shared = (_solid(first) ^ _solid(second)).volume()
    assert len(report.part_faces) == 2
    assert (len(report.overlapping) > 0) == (shared > 1e-9), (offset, shared)
    if shared > 1e-9:
        assert report.overlapping.tolist() == [[0, 1]]


def test_a_box_inside_a_box_has_its_twelve_faces_buried():
    outer, inner = _box(4.0), _box(1.0, at=(0.5, 0.2, -0.3))
    report = inspect_soup(_mesh(outer, inner))
    assert (_solid(outer) ^ _solid(inner)).volume() == pytest.approx(1.0)
    assert report.overlapping.tolist() == [[0, 1]]
    assert report.buried_faces == len(inner.faces) == 12


def test_buried_faces_agree_with_libigl():
    parts = [_box(), _box(at=(1.0, 0.5, 0.25)), trimesh.creation.icosphere(2, 0.8)]
    mesh = _mesh(*parts)
    report = inspect_soup(mesh)
    triangles = mesh.vertices[mesh.faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    step = SIDE_OFFSET * np.linalg.norm(np.ptp(mesh.vertices, axis=0))
    centres = triangles.mean(axis=1)
    sides = [
        igl.winding_number(mesh.vertices, mesh.faces, centres + sign * step * normals)
        for sign in (1, -1)
    ]
    expected = int(((sides[0] >= 0.5) & (sides[1] >= 0.5)).sum())
    assert report.buried_faces == expected > 0
    assert len(report.overlapping) == 3


def test_a_flipped_box_is_inside_out():
    box = _box(at=(5.0, 0.0, 0.0))
    flipped = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    report = inspect_soup(_mesh(_box(), flipped))
    assert flipped.volume < 0
    centre = np.array([[5.0, 0.0, 0.0]])
    assert igl.winding_number(flipped.vertices, flipped.faces, centre)[0] == pytest.approx(-1)
    assert report.inside_out.tolist() == [1]
    assert report.part_volume[1] == pytest.approx(flipped.volume)
    assert report.misoriented_edges == 0
    assert report.buried_faces == 0


def test_a_sheet_encloses_no_volume():
    square = trimesh.Trimesh(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]], process=False
    )
    report = inspect_soup(_mesh(square))
    assert not report.encloses_volume
    assert report.boundary_edges == 4
    assert report.hole_edges.tolist() == [4]
    assert report.hole_centres[0] == pytest.approx([0.5, 0.5, 0.0])


def test_a_non_manifold_edge_is_found():
    box = _box()
    edge = box.edges_unique[0]
    fin = trimesh.Trimesh(np.vstack([box.vertices[edge], [[5.0, 5.0, 5.0]]]), [[0, 1, 2]])
    report = inspect_soup(_mesh(box, fin))
    assert report.non_manifold_edges == 1
    assert report.non_manifold_at == pytest.approx(box.vertices[edge].mean(axis=0))
    assert report.boundary_edges == 2
    assert len(report.part_faces) == 1


def test_a_flipped_face_is_misoriented_along_its_three_edges():
    box = _box()
    faces = box.faces.copy()
    faces[0] = faces[0, ::-1]
    reference = trimesh.Trimesh(box.vertices, faces, process=False)
    report = inspect_soup(_mesh(reference))
    assert not reference.is_winding_consistent
    assert report.misoriented_edges == 3
    assert report.boundary_edges == report.non_manifold_edges == 0
