"""``shellvox info`` reports a model as it comes (exit 0): open, many parts, overlapping,
buried faces, inside out; checked with trimesh's edges and parts and manifold3d's solids."""

from __future__ import annotations

import json

import manifold3d
import numpy as np
import pytest
import trimesh
from conftest import shared_path

from shellvox.cli import main
from shellvox.errors import InputError
from shellvox.loading import load_model


def _write(path, *parts: trimesh.Trimesh):
    lines, start = [], 1
    for part in parts:
        lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in part.vertices]
        lines += [f"f {a + start} {b + start} {c + start}" for a, b, c in part.faces]
        start += len(part.vertices)
    path.write_text("\n".join(lines) + "\n")
    return path


def _box(size=10.0, at=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(size,) * 3).apply_translation(at)


def _info(capsys, path, *options):
    assert main(["info", "--json", *options, str(path)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    return json.loads(captured.out)


def _solid(part: trimesh.Trimesh) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh(
            vert_properties=np.asarray(part.vertices, np.float32),
            tri_verts=np.asarray(part.faces, np.uint32),
        )
    )


def test_the_open_teapot_is_reported_not_refused(capsys):
    path = shared_path("teapot/teapot.obj")
    summary = _info(capsys, path)
    reference = trimesh.load(path, force="mesh")
    single = trimesh.grouping.group_rows(np.sort(reference.edges, axis=1), require_count=1)
    assert not summary["closed"]
    assert summary["boundary_edges"] == len(single) > 0
    assert summary["parts"] == len(reference.split(only_watertight=False))
    assert summary["holes"] >= len(summary["holes_at_mm"]) > 0
    assert summary["unit"] == "mm"
    # The listed holes are loops of trimesh's outline: the same edges, the same centre.
    outline = reference.outline()
    loops = [
        (len(entity.points) - 1, outline.vertices[np.unique(entity.points)].mean(axis=0))
        for entity in outline.entities
    ]
    assert summary["holes"] == len(loops)
    for centre, edges in summary["holes_at_mm"]:
        assert any(n == edges and np.allclose(c, centre, atol=1e-6) for n, c in loops)
    assert [edges for _, edges in summary["holes_at_mm"]] == sorted(n for n, _ in loops)[::-1][:3]
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert f"no: {len(single)} boundary edges in {summary['holes']} holes" in text


def test_two_overlapping_boxes(tmp_path, capsys):
    first, second = _box(), _box(at=(4.0, 3.0, 2.0))
    assert (_solid(first) ^ _solid(second)).volume() > 0
    summary = _info(capsys, _write(tmp_path / "two.obj", first, second))
    assert summary["closed"] and summary["parts"] == 2
    assert summary["overlapping_parts"] == [[1, 2]]
    assert main(["info", str(tmp_path / "two.obj")]) == 0
    assert "1 pairs: parts 1 and 2" in capsys.readouterr().out


def test_a_box_inside_a_box_buries_its_twelve_faces(tmp_path, capsys):
    outer, inner = _box(20.0), _box(5.0, at=(2.0, -1.0, 3.0))
    assert (_solid(outer) ^ _solid(inner)).volume() == pytest.approx(125.0)
    summary = _info(capsys, _write(tmp_path / "nested.obj", outer, inner))
    assert summary["buried_faces"] == len(inner.faces) == 12
    assert summary["overlapping_parts"] == [[1, 2]]


def test_a_flipped_box_is_reported_inside_out(tmp_path, capsys):
    box = _box()
    flipped = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    assert flipped.volume < 0
    path = _write(tmp_path / "flipped.obj", flipped)
    summary = _info(capsys, path)
    assert summary["inside_out_parts"] == [1]
    assert summary["oriented"]  # consistently, the wrong way
    assert main(["info", str(path)]) == 0
    assert "inside out: part 1" in capsys.readouterr().out


def test_a_sheet_is_reported_as_enclosing_no_volume(tmp_path, capsys):
    # Two copies of one triangle facing opposite ways: closed, oriented, no volume.
    sheet = trimesh.Trimesh(
        [[0, 0, 0], [10, 0, 0], [0, 10, 0]], [[0, 1, 2], [0, 2, 1]], process=False
    )
    path = _write(tmp_path / "flat.obj", sheet)
    assert not _info(capsys, path)["encloses_volume"]
    assert main(["info", str(path)]) == 0
    assert "encloses no volume" in capsys.readouterr().out
    with pytest.raises(InputError, match="encloses no volume"):
        load_model(path)  # what is built is still refused
