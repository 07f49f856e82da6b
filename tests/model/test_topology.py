"""Topology: seams merged, inside-out flipped, zero-area dropped, holes repaired on request."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from builders import TET_FACES, TET_VERTICES

from shellvox.errors import InputError
from shellvox.model import ColouredMesh, edge_report, prepare, signed_volume


def _unshared(faces=TET_FACES, vertices=TET_VERTICES):
    """Every face with its own three vertices, as textured exports have them."""
    corners = vertices[faces].reshape(-1, 3)
    return ColouredMesh(corners, np.arange(len(corners)).reshape(-1, 3), source="test")


def test_seam_split_vertices_are_merged_for_topology():
    raw = _unshared()
    assert not edge_report(raw.faces).closed
    mesh = prepare(raw)
    assert len(mesh.vertices) == 4
    assert edge_report(mesh.faces).oriented
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(1000 / 6)


def test_inside_out_mesh_is_flipped_with_a_warning():
    raw = _unshared(faces=TET_FACES[:, ::-1])
    with pytest.warns(UserWarning, match="inside out"):
        mesh = prepare(raw)
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(1000 / 6)


def test_zero_area_faces_are_dropped_with_a_warning():
    faces = np.vstack([TET_FACES, [[0, 1, 1]]])
    with pytest.warns(UserWarning, match="dropped 1 zero-area"):
        mesh = prepare(_unshared(faces=faces))
    assert len(mesh.faces) == 4


def test_repair_closes_a_hole_with_a_warning():
    box = trimesh.creation.box(extents=(10, 20, 30))
    raw = ColouredMesh(np.asarray(box.vertices), np.asarray(box.faces[1:]), source="box")
    with pytest.raises(InputError, match="boundary edges"):
        prepare(raw)
    with pytest.warns(UserWarning, match=r"LoadOptions\(repair=True\) closed"):
        mesh = prepare(raw, repair=True)
    assert edge_report(mesh.faces).oriented
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(6000.0)


def test_inconsistent_winding_is_refused_or_repaired():
    faces = TET_FACES.copy()
    faces[1] = faces[1, ::-1]
    raw = _unshared(faces=faces)
    with pytest.raises(InputError, match="inconsistently oriented"):
        prepare(raw)
    with pytest.warns(UserWarning, match="re-oriented|inside out") as record:
        mesh = prepare(raw, repair=True)
    assert any("re-oriented" in str(w.message) for w in record)
    assert edge_report(mesh.faces).oriented
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(1000 / 6)


def test_merge_by_position_matches_a_slow_reference():
    from shellvox.model import merge_by_position

    rng = np.random.default_rng(3)
    points = rng.integers(0, 5, size=(400, 3)).astype(np.float64)  # many repeated rows
    faces = rng.integers(0, 400, size=(300, 3))
    merged = merge_by_position(ColouredMesh(points, faces, source="t"))
    assert len(merged.vertices) == len(np.unique(points, axis=0))
    np.testing.assert_array_equal(merged.vertices[merged.faces], points[faces])


def test_edge_report_matches_a_slow_reference():
    box = trimesh.creation.icosphere(subdivisions=2)
    faces = np.asarray(box.faces)[5:]  # open it: the removed faces leave boundary edges
    report = edge_report(faces)
    counts: dict[tuple[int, int], int] = {}
    for a, b, c in faces.tolist():
        for e in ((a, b), (b, c), (c, a)):
            key = (min(e), max(e))
            counts[key] = counts.get(key, 0) + 1
    expected = sorted(k for k, n in counts.items() if n == 1)
    assert sorted(map(tuple, report.boundary.tolist())) == expected
    assert len(report.misoriented) == 0
