"""``repair`` works part by part: every part is kept, closed and outward, or the model is
refused naming the part; checked with trimesh's parts and volumes and pymeshfix itself."""

from __future__ import annotations

import numpy as np
import pymeshfix
import pytest
import trimesh
from conftest import shared_path

from shellvox.config import LoadOptions
from shellvox.errors import InputError
from shellvox.loading import load_model
from shellvox.model import ColouredMesh, edge_report, prepare


def _soup(parts: list[trimesh.Trimesh]) -> ColouredMesh:
    starts = np.cumsum([0] + [len(p.vertices) for p in parts])
    vertices = np.concatenate([p.vertices for p in parts])
    faces = np.concatenate([p.faces + s for p, s in zip(parts, starts, strict=False)])
    return ColouredMesh(vertices, faces, source="parts.obj")


def _box_without_a_face(x: float) -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=(2.0, 3.0, 4.0)).apply_translation((x, 0, 0))
    return trimesh.Trimesh(box.vertices, box.faces[1:], process=False)


def _sphere_without_a_cap(x: float) -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.5).apply_translation((x, 0, 0))
    keep = sphere.triangles_center[:, 2] < 1.0
    return trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)


def _many_open_parts() -> list[trimesh.Trimesh]:
    """Separate parts, all but one open (as a many-part character comes), one inside out."""
    inside_out = trimesh.creation.box(extents=(1.0, 1.0, 1.0)).apply_translation((25, 0, 0))
    inside_out = trimesh.Trimesh(inside_out.vertices, inside_out.faces[:, ::-1], process=False)
    return [
        _box_without_a_face(0.0),
        _sphere_without_a_cap(5.0),
        _box_without_a_face(10.0),
        _sphere_without_a_cap(15.0),
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).apply_translation((20, 0, 0)),
        inside_out,
    ]


def test_repair_keeps_every_part_closed_and_outward():
    parts = _many_open_parts()
    # pymeshfix alone on the whole model keeps one part: what the repair must not do.
    whole = _soup(parts)
    fixed = trimesh.Trimesh(
        *pymeshfix.clean_from_arrays(
            np.ascontiguousarray(whole.vertices), np.ascontiguousarray(whole.faces, np.int32)
        )
    )
    assert len(fixed.split(only_watertight=False)) == 1
    with pytest.warns(UserWarning, match=r"repair=True\) closed .* in 4 of 6 parts") as record:
        mesh = prepare(whole, repair=True)
    assert len(record) == 1
    assert "turned 1 inside-out parts outside out (part 6)" in str(record[0].message)
    assert edge_report(mesh.faces).oriented
    repaired = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).split(
        only_watertight=False
    )
    assert len(repaired) == len(parts)
    by_x = sorted(repaired, key=lambda p: p.bounds[:, 0].mean())
    for before, after in zip(parts, by_x, strict=True):
        assert after.is_watertight
        assert after.volume > 0
        # Every face of the part is still there (holes only add faces).
        assert len(after.faces) >= len(before.faces)
        assert np.allclose(after.bounds, before.bounds)
    # Boxes with one face missing close exactly; the closed boxes keep their volume.
    for index in (0, 2):
        assert by_x[index].volume == pytest.approx(24.0)
    assert by_x[4].volume == pytest.approx(1.0)
    assert by_x[5].volume == pytest.approx(1.0)
    # A sphere with its cap cut off closes to at most the whole sphere's volume.
    for index in (1, 3):
        assert 0.5 * 4 / 3 * np.pi * 1.5**3 < by_x[index].volume < 4 / 3 * np.pi * 1.5**3


def test_a_part_meshfix_would_drop_is_refused_naming_it():
    sheet = trimesh.Trimesh(
        [[30, 0, 0], [31, 0, 0], [31, 1, 0], [30, 1, 0]], [[0, 1, 2], [0, 2, 3]], process=False
    )
    _, kept = pymeshfix.clean_from_arrays(
        np.ascontiguousarray(sheet.vertices, np.float64),
        np.ascontiguousarray(sheet.faces, np.int32),
    )
    assert len(kept) == 0  # MeshFix loses this part
    with pytest.raises(InputError) as caught:
        prepare(_soup([_box_without_a_face(0.0), _sphere_without_a_cap(5.0), sheet]), repair=True)
    message = str(caught.value)
    assert "\n" not in message
    assert "part 3 of 3 (2 faces, around (30.5, 0.5, 0) mm) would be lost" in message
    assert "part 1" not in message and "part 2" not in message


def test_a_cavity_keeps_its_orientation():
    outer = trimesh.creation.box(extents=(4.0, 4.0, 4.0))
    cavity = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    cavity = trimesh.Trimesh(cavity.vertices, cavity.faces[:, ::-1], process=False)
    hollow = _soup([trimesh.Trimesh(outer.vertices, outer.faces[1:], process=False), cavity])
    with pytest.warns(UserWarning, match=r"closed 3 boundary edges in 1 of 2 parts") as record:
        mesh = prepare(hollow, repair=True)
    assert "outside out" not in str(record[0].message)
    solid = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert solid.volume == pytest.approx(64.0 - 1.0)


def test_the_open_teapot_keeps_its_four_parts():
    path = shared_path("teapot/teapot.obj")
    reference = trimesh.load(path, force="mesh").split(only_watertight=False)
    with pytest.warns(UserWarning, match=r"closed \d+ boundary edges in 4 of 4 parts"):
        mesh = load_model(path, LoadOptions(repair=True))
    parts = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).split(only_watertight=False)
    assert len(parts) == len(reference) == 4
    for before, after in zip(
        sorted(reference, key=lambda p: tuple(p.bounds.ravel())),
        sorted(parts, key=lambda p: tuple(p.bounds.ravel())),
        strict=True,
    ):
        assert after.is_watertight and after.volume > 0
        assert len(after.faces) >= len(before.faces)
        assert np.allclose(after.bounds, before.bounds)
