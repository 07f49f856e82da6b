"""Robust and paper offsets against analytic answers: boxes, spheres, plates, reflex corners."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
import trimesh

from shellvox.offset import Shell, offset_shells, shell_report
from shellvox.offset.quality.measures import equidistance, mesh_checks
from shellvox.offset.reference.band import ARC_STEP_RAD


def _tm(shell: Shell) -> trimesh.Trimesh:
    return trimesh.Trimesh(shell.vertices, shell.faces, process=False)


def _assert_valid(shell: Shell) -> None:
    mesh = _tm(shell)
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    assert mesh.volume > 0


def test_box_uniform_is_exact():
    box = trimesh.creation.box((10.0, 20.0, 30.0))
    shells = offset_shells(box.vertices, box.faces, [0.5, 1.0], method="robust")
    for shell, d in zip(shells, [0.5, 1.5], strict=True):
        _assert_valid(shell)
        half = np.array([5.0, 10.0, 15.0]) - d
        assert np.abs(shell.vertices.min(axis=0) + half).max() <= 1e-9
        assert np.abs(shell.vertices.max(axis=0) - half).max() <= 1e-9
        assert _tm(shell).volume == pytest.approx(np.prod(2 * half), rel=1e-12)
        np.testing.assert_array_equal(shell.depth_mm, np.full(12, d))
    assert [s.layer for s in shells] == [1, 2]


def test_box_with_a_thickness_per_face_keeps_every_face_at_its_own_distance():
    """The paper's Fig. 5 check: every offset face on its own moved plane, shell closed."""
    box = trimesh.creation.box((10.0, 20.0, 30.0))
    normals = np.asarray(box.face_normals)
    # Thickness per axis direction -x, +x, -y, +y, -z, +z.
    per_dir = {(-1, 0): 0.3, (1, 0): 0.7, (-1, 1): 1.1, (1, 1): 0.2, (-1, 2): 2.5, (1, 2): 0.9}
    axis = np.argmax(np.abs(normals), axis=1)
    sign = np.sign(normals[np.arange(12), axis]).astype(int)
    t = np.array([per_dir[(s, a)] for s, a in zip(sign, axis, strict=True)])
    (shell,) = offset_shells(box.vertices, box.faces, t[None, :], method="robust")
    _assert_valid(shell)
    half = np.array([5.0, 10.0, 15.0])
    lo = -half + [per_dir[(-1, i)] for i in range(3)]
    hi = half - [per_dir[(1, i)] for i in range(3)]
    # Every face lies on one moved plane (vertices may sit inside a face or on an edge).
    np.testing.assert_allclose(shell.vertices.min(axis=0), lo, rtol=0, atol=1e-9)
    np.testing.assert_allclose(shell.vertices.max(axis=0), hi, rtol=0, atol=1e-9)
    on_plane = (np.abs(shell.vertices - lo) <= 1e-9) | (np.abs(shell.vertices - hi) <= 1e-9)
    assert np.all(on_plane.sum(axis=1) >= 1)
    tri = shell.vertices[shell.faces]
    flat = np.all(np.abs(tri - tri[:, :1]) <= 1e-9, axis=1)  # (m, 3): constant coordinate
    assert np.all(flat.sum(axis=1) == 1)
    assert np.all(on_plane[shell.faces].all(axis=1)[flat])
    assert _tm(shell).volume == pytest.approx(np.prod(hi - lo), rel=1e-12)


def test_icosphere_is_equidistant():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=10.0)
    shells = offset_shells(sphere.vertices, sphere.faces, [0.5], method="robust")
    _assert_valid(shells[0])
    report = shell_report(
        sphere.vertices, sphere.faces, [0.5], shells, baselines=False, n_samples=4000
    )
    layer = report["layers"][0]["shell"]
    assert layer["self_intersections"] == 0
    assert layer["nested"]
    assert layer["equidistance"]["error_pct"]["p99"] <= 0.5
    assert layer["equidistance"]["error_pct"]["max"] <= 1e-6


def test_report_takes_the_checks_of_the_files_read_back():
    box = trimesh.creation.box((10.0, 10.0, 10.0))
    shells = offset_shells(box.vertices, box.faces, [0.5, 1.0], method="robust")
    measured = shell_report(box.vertices, box.faces, [0.5, 1.0], shells, baselines=False)
    given = [mesh_checks(s.vertices, s.faces) for s in shells]
    assert given[0]["closed"] and given[0]["self_intersections"] == 0
    reused = shell_report(
        box.vertices, box.faces, [0.5, 1.0], shells, baselines=False, checks=given
    )
    assert reused == measured
    with pytest.raises(ValueError, match="one entry per shell"):
        shell_report(box.vertices, box.faces, [0.5, 1.0], shells, checks=given[:1])


def test_thin_plate_collapses_cleanly():
    plate = trimesh.creation.box((20.0, 20.0, 1.0))
    shells = offset_shells(plate.vertices, plate.faces, [0.3, 0.5], method="robust")
    _assert_valid(shells[0])
    assert shells[0].vertices[:, 2].max() == pytest.approx(0.2, abs=1e-12)
    assert shells[1].faces.shape == (0, 3)  # 0.8 mm from both sides of a 1 mm plate
    report = shell_report(
        plate.vertices, plate.faces, [0.3, 0.5], shells, baselines=False, n_samples=500
    )
    assert report["layers"][1]["shell"]["n_faces"] == 0
    assert report["layers"][1]["shell"]["nested"]
    # The paper's planes cross instead: the top face ends up below the bottom one.
    (paper,) = offset_shells(plate.vertices, plate.faces, [0.8], method="paper")
    top = np.asarray(plate.face_normals)[:, 2] > 0.5
    assert (
        paper.vertices[paper.faces[top]][..., 2].max()
        < paper.vertices[paper.faces[~top & (np.asarray(plate.face_normals)[:, 2] < -0.5)]][
            ..., 2
        ].min()
    )


def _l_block() -> trimesh.Trimesh:
    outline = shapely.Polygon([(0, 0), (20, 0), (20, 8), (8, 8), (8, 20), (0, 20)])
    return trimesh.creation.extrude_polygon(outline, 10.0)


def test_reflex_edge_is_rounded_not_creased():
    block = _l_block()
    d = 1.0
    (robust,) = offset_shells(block.vertices, block.faces, [d], method="robust")
    (paper,) = offset_shells(block.vertices, block.faces, [d], method="paper")
    _assert_valid(robust)
    # Robust: never deeper than d, at most the polygonal arc's sagitta shallower
    # (a 90 degree arc in steps of at most ARC_STEP_RAD).
    stats = equidistance(block, np.full(len(block.faces), d), robust.vertices)
    steps = np.ceil((np.pi / 2) / ARC_STEP_RAD)
    assert stats["error_pct"]["max"] <= 100 * (1 - np.cos(np.pi / 4 / steps)) + 1e-6
    # The paper's crease at the 90 degree inner corner is sqrt(2) d deep (41 % too deep).
    crease = paper.vertices[np.abs(paper.vertices[:, :2] - (8.0 - d)).max(axis=1) <= 1e-9]
    np.testing.assert_allclose(np.sort(crease[:, 2]), [d, 10.0 - d], rtol=0, atol=1e-9)
    depth = trimesh.proximity.closest_point(block, crease.mean(axis=0, keepdims=True))[1]
    np.testing.assert_allclose(depth, np.sqrt(2) * d, rtol=1e-9)


def test_offset_prints_nothing(capfd):
    """Library code (and the C++ it calls) reports through return values and warnings."""
    block = _l_block()
    offset_shells(block.vertices, block.faces, [0.5, 0.5], method="robust")
    offset_shells(block.vertices, block.faces, [0.5], method="paper")
    captured = capfd.readouterr()
    assert captured.out == ""
    assert captured.err == ""


def test_report_of_shells_tested_together_needs_no_second_crossing_test(monkeypatch):
    # Nesting of shell 2 in shell 1 without the crossing test when both were tested
    # together: the same report; layer 1 in the surface is still tested.
    from shellvox.offset.quality import measures as quality

    box = trimesh.creation.box((10.0, 10.0, 10.0))
    shells = offset_shells(box.vertices, box.faces, [0.5, 1.0], method="robust")
    measured = shell_report(box.vertices, box.faces, [0.5, 1.0], shells, baselines=False)
    pairs = quality.intersecting_pairs
    tested = []

    def counted(v, f, **kw):
        tested.append(float(np.abs(v).max()))  # the outer of the two meshes tested
        return pairs(v, f, **kw)

    monkeypatch.setattr(quality, "intersecting_pairs", counted)
    reused = shell_report(
        box.vertices, box.faces, [0.5, 1.0], shells, baselines=False, crossing_free=True
    )
    assert reused == measured
    assert tested == [5.0]  # layer 1 in the surface (half the box's 10 mm), not 2 in 1
