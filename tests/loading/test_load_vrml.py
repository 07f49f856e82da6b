"""VRML 2.0 against an independent reader (pymeshlab, MeshLab's VRML importer) and by hand.

Each file is written here from ISO/IEC 14772-1 (IndexedFaceSet 6.23, Transform 6.52).
pymeshlab reads geometry, transforms, per-face colours, per-vertex colours without
``colorIndex`` and texture coordinates; per-corner colours through ``colorIndex`` (which
MeshLab drops) and the texture's colours are checked against hand-computed values.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from builders import TET_FACES, TET_VERTICES, locate, marker_image, png_bytes

from shellvox.cli import main
from shellvox.errors import InputError, ShellvoxWarning
from shellvox.loading import load_model
from shellvox.testing import meshlab_read

pytest.importorskip("pymeshlab")  # the reference reader (in a process of its own)

POINTS = ", ".join(" ".join(str(c) for c in p) for p in TET_VERTICES)
COORD_INDEX = " ".join(" ".join(str(v) for v in f) + " -1" for f in TET_FACES)
COLOURS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=float)
COLOUR_TEXT = ", ".join(" ".join(f"{c:g}" for c in row) for row in COLOURS)


def _face_set(extra: str, coord: str = f"Coordinate {{ point [ {POINTS} ] }}") -> str:
    return f"IndexedFaceSet {{ coord {coord} coordIndex [ {COORD_INDEX} ] {extra} }}"


def _write(path, body: str) -> None:
    path.write_text("#VRML V2.0 utf8\n# written by hand for shellvox's tests\n" + body + "\n")


def _colour_at(mesh, point) -> list[int]:
    fid, bary = locate(mesh, np.asarray(point, float))
    return mesh.colour_at(fid, bary)[0].tolist()


def _corner(mesh, corner: np.ndarray, towards: np.ndarray) -> list[int]:
    """Colour at ``corner`` of the face that contains the point just off it ``towards``."""
    fid, _ = locate(mesh, corner * 0.999 + towards * 0.001)
    local = int(np.flatnonzero(np.isclose(mesh.vertices[mesh.faces[fid[0]]], corner).all(1))[0])
    return mesh.colour_at(fid, np.eye(3)[local][None])[0].tolist()


def test_per_face_colours_and_nested_transforms_match_meshlab(tmp_path):
    path = tmp_path / "faces.wrl"
    extra = f"color Color {{ color [ {COLOUR_TEXT} ] }} colorPerVertex FALSE colorIndex [ 3 2 1 0 ]"
    shape = f"Shape {{ geometry {_face_set(extra)} }}"
    _write(
        path,
        "DEF OUTER Transform { translation 5 -2 1 rotation 0 0 1 1.5707963267948966 "
        "scale 2 1 3 scaleOrientation 1 0 0 0.3 center 1 1 1 children [ "
        f"Group {{ children [ Transform {{ translation 0 0 4 children [ {shape} ] }} ] }} ] }}",
    )
    mesh = load_model(path)
    assert mesh.colour_kind == "face"
    reference = meshlab_read(path)
    expected_vertices = reference["vertices"]
    for vertex in expected_vertices:
        assert np.isclose(mesh.vertices, vertex, atol=1e-6).all(1).any(), vertex
    face_colours = np.rint(reference["face_colours"] * 255).astype(int)
    for face, rgba in zip(reference["faces"], face_colours, strict=True):
        assert _colour_at(mesh, expected_vertices[face].mean(0)) == rgba.tolist()


def test_per_vertex_colours_match_meshlab(tmp_path):
    path = tmp_path / "vertices.wrl"
    _write(path, f"Shape {{ geometry {_face_set(f'color Color {{ color [ {COLOUR_TEXT} ] }}')} }}")
    mesh = load_model(path)
    assert mesh.colour_kind == "vertex"
    reference = meshlab_read(path)
    colours = np.rint(reference["vertex_colours"] * 255).astype(int)
    for vertex, rgba in zip(reference["vertices"], colours, strict=True):
        for face in TET_FACES:  # the same colour at this corner of every face around it
            if np.isclose(TET_VERTICES[face], vertex).all(1).any():
                assert _corner(mesh, vertex, TET_VERTICES[face].mean(0)) == rgba.tolist()


def test_per_corner_colours_through_colour_index(tmp_path):
    # colorIndex laid out like coordIndex: each face corner has its own colour.
    index = [[0, 1, 2], [3, 3, 3], [2, 1, 0], [1, 1, 2]]
    text = " ".join(" ".join(str(i) for i in row) + " -1" for row in index)
    path = tmp_path / "corners.wrl"
    extra = f"color Color {{ color [ {COLOUR_TEXT} ] }} colorIndex [ {text} ]"
    _write(path, f"Shape {{ geometry {_face_set(extra)} }}")
    mesh = load_model(path)
    for face, row in zip(TET_FACES, index, strict=True):
        for corner, colour_id in zip(face, row, strict=True):
            got = _corner(mesh, TET_VERTICES[corner], TET_VERTICES[face].mean(0))
            assert got == [*(COLOURS[colour_id] * 255).astype(int).tolist(), 255]


def test_texture_coordinates_match_meshlab_and_the_marker_lands(tmp_path):
    width, height, row, col = 32, 16, 8, 9
    (tmp_path / "tex.png").write_bytes(png_bytes(marker_image(width, height, row, col)))
    uv = np.array([[0.05, 0.05], [0.95, 0.05], [0.05, 0.95]])
    points = ", ".join(f"{u} {v}" for u, v in uv)
    path = tmp_path / "textured.wrl"
    extra = (
        f"texCoord TextureCoordinate {{ point [ {points} ] }} "
        "texCoordIndex [ 0 1 2 -1 0 1 2 -1 0 1 2 -1 0 1 2 -1 ]"
    )
    look = 'Appearance { texture ImageTexture { url [ "gone.png" "tex.png" ] } }'
    _write(path, f"Shape {{ appearance {look} geometry {_face_set(extra)} }}")
    mesh = load_model(path)
    assert mesh.colour_kind == "texture"
    reference = meshlab_read(path)
    wedges = reference["wedge_uv"].reshape(-1, 3, 2)
    for face, corners in zip(reference["faces"], wedges, strict=True):
        triangle = reference["vertices"][face]
        centre = triangle.mean(0)
        for vertex, expected in zip(triangle, corners, strict=True):
            fid, _ = locate(mesh, vertex * 0.999 + centre * 0.001)
            local = np.flatnonzero(np.isclose(mesh.vertices[mesh.faces[fid[0]]], vertex).all(1))
            np.testing.assert_allclose(mesh.corner_uv[fid[0], local[0]], expected, atol=1e-6)
    # VRML's texture origin is the bottom-left: texel (row, col) is at v = 1 - (row + .5)/H.
    target = np.array([(col + 0.5) / width, 1 - (row + 0.5) / height])
    b1, b2 = (target - uv[0]) / 0.9
    point = np.array([1 - b1 - b2, b1, b2]) @ TET_VERTICES[TET_FACES[0]]
    assert _colour_at(mesh, point) == [255, 0, 0, 255]


def test_material_colour_and_transparency(tmp_path):
    path = tmp_path / "material.wrl"
    _write(
        path,
        "Shape { appearance Appearance { material Material { diffuseColor 0.2 0.4 0.6 "
        f"transparency 0.25 }} }} geometry {_face_set('')} }}",
    )
    mesh = load_model(path)
    assert mesh.colour_kind == "face"
    assert mesh.face_rgba[0].tolist() == [51, 102, 153, round(0.75 * 255)]


def test_info_reports_the_colour_kind(tmp_path, capsys):
    path = tmp_path / "vertices.wrl"
    _write(path, f"Shape {{ geometry {_face_set(f'color Color {{ color [ {COLOUR_TEXT} ] }}')} }}")
    assert main(["info", "--json", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["colour"] == "vertex"


def test_unread_nodes_are_named_and_bad_files_refused(tmp_path):
    path = tmp_path / "box.wrl"
    _write(path, f"Shape {{ geometry Box {{ }} }} Shape {{ geometry {_face_set('')} }}")
    with pytest.warns(ShellvoxWarning, match="Box are not read"):
        assert load_model(path).colour_kind == "none"
    (tmp_path / "v1.wrl").write_text("#VRML V1.0 ascii\nSeparator { }\n")
    with pytest.raises(InputError, match=r"is not VRML 2\.0"):
        load_model(tmp_path / "v1.wrl")
    _write(tmp_path / "cut.wrl", f"Shape {{ geometry {_face_set('')}")
    with pytest.raises(InputError, match="line 4: expected a name, found the end of the file"):
        load_model(tmp_path / "cut.wrl")
    short = tmp_path / "short.wrl"
    _write(
        short,
        f"Shape {{ geometry {_face_set('color Color { color [ 1 0 0 ] } colorIndex [ 0 ]')} }}",
    )
    with pytest.raises(InputError, match="colorIndex has 1 entries"):
        load_model(short)
