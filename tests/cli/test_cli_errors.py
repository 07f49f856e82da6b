"""Bad input: one line on stderr naming the file, the problem and the fix; exit status 2."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest
from builders import TET_FACES, TET_VERTICES, marker_image, write_3mf, write_obj

from shellvox.cli import main

UV = np.tile(np.array([[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]]), (4, 1, 1))


def _tet_obj(path, faces=TET_FACES, vertices=TET_VERTICES):
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(v + 1) for v in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def _refused(capsys, argv, *needles):
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("shellvox: error: ")
    assert "Traceback" not in err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def test_missing_file(tmp_path, capsys):
    _refused(capsys, ["info", str(tmp_path / "nope.obj")], "nope.obj", "not found")


def test_unknown_format(tmp_path, capsys):
    (tmp_path / "m.xyz").write_text("1 2 3\n")
    _refused(capsys, ["info", str(tmp_path / "m.xyz")], "m.xyz", "unknown model format", ".3mf")


def test_empty_file(tmp_path, capsys):
    (tmp_path / "m.stl").write_bytes(b"")
    _refused(capsys, ["info", str(tmp_path / "m.stl")], "m.stl", "empty")


def test_zero_volume_mesh(tmp_path, capsys):
    # Two copies of one triangle, facing opposite ways: closed, oriented, no volume.
    path = _tet_obj(tmp_path / "flat.obj", faces=np.array([[0, 1, 2], [0, 2, 1]]))
    argv = ["thickness", str(path), "-o", str(tmp_path / "out")]
    _refused(capsys, argv, "flat.obj", "encloses no volume")


def test_nan_coordinates(tmp_path, capsys):
    vertices = TET_VERTICES.copy()
    vertices[2, 1] = np.nan
    path = _tet_obj(tmp_path / "nan.obj", vertices=vertices)
    _refused(capsys, ["info", str(path)], "nan.obj", "NaN")


def test_missing_texture_is_refused_without_fallback(tmp_path, capsys):
    write_obj(tmp_path / "m.obj", UV, None, map_kd="gone.png")
    _refused(capsys, ["info", str(tmp_path / "m.obj")], "model.mtl", "gone.png", "--colour")


def test_missing_texture_with_colour_fallback_warns(tmp_path, capsys):
    write_obj(tmp_path / "m.obj", UV, None, map_kd="gone.png")
    status = main(["info", "--json", "--colour", "10,20,30", str(tmp_path / "m.obj")])
    captured = capsys.readouterr()
    assert status == 0
    assert "warning" in captured.err and "gone.png" in captured.err
    summary = json.loads(captured.out)
    assert summary["colour"] == "face" and summary["distinct_colours"] == 1


def test_unreadable_texture(tmp_path, capsys):
    write_obj(tmp_path / "m.obj", UV, None, map_kd="bad.png")
    (tmp_path / "bad.png").write_bytes(b"this is not a png")
    _refused(capsys, ["info", str(tmp_path / "m.obj")], "bad.png", "unreadable")


def test_3mf_entry_escaping_the_archive(tmp_path, capsys):
    write_3mf(tmp_path / "evil.3mf", extra_entries={"../../etc/evil.txt": b"x"})
    _refused(capsys, ["info", str(tmp_path / "evil.3mf")], "evil.3mf", "escapes the archive")


def test_3mf_zip_bomb(tmp_path, capsys):
    path = tmp_path / "bomb.3mf"
    write_3mf(path)
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("3D/padding.bin", b"\0" * (80 * 1024 * 1024))
    _refused(capsys, ["info", str(path)], "bomb.3mf", "zip bomb")


def test_too_many_faces_without_force(tmp_path, capsys):
    path = _tet_obj(tmp_path / "big.obj")
    _refused(capsys, ["info", "--max-faces", "3", str(path)], "big.obj", "--force")
    assert main(["info", "--max-faces", "3", "--force", str(path)]) == 0


def test_open_mesh_names_count_and_location(tmp_path, capsys):
    path = _tet_obj(tmp_path / "open.obj", faces=TET_FACES[:3])
    argv = ["thickness", str(path), "-o", str(tmp_path / "out")]
    line = _refused(capsys, argv, "open.obj", "3 boundary edges", "--repair")
    assert " mm" in line


def test_non_manifold_edge(tmp_path, capsys):
    vertices = np.vstack([TET_VERTICES, [[5.0, 5.0, -10.0]]])
    faces = np.vstack([TET_FACES, [[0, 1, 4]]])
    path = _tet_obj(tmp_path / "fin.obj", faces=faces, vertices=vertices)
    argv = ["thickness", str(path), "-o", str(tmp_path / "out")]
    _refused(capsys, argv, "fin.obj", "non-manifold")


def test_bad_colour_option(tmp_path, capsys):
    path = _tet_obj(tmp_path / "m.obj")
    _refused(capsys, ["info", "--colour", "300,0,0", str(path)], "--colour", "0-255")


def test_teapot_is_refused_as_open(shared_mesh, capsys, tmp_path):
    path = shared_mesh("teapot/teapot.obj")
    argv = ["thickness", str(path), "-o", str(tmp_path / "out")]
    _refused(capsys, argv, "teapot.obj", "open", "boundary edges")


def test_missing_mtl_is_refused(tmp_path, capsys):
    write_obj(tmp_path / "m.obj", UV, marker_image(8, 8, 1, 1), write_mtl=False)
    _refused(capsys, ["info", str(tmp_path / "m.obj")], "m.obj", "model.mtl", "--texture")


@pytest.mark.parametrize("suffix", [".stl", ".ply", ".glb", ".off"])
def test_garbage_in_known_format(tmp_path, capsys, suffix):
    path = tmp_path / f"junk{suffix}"
    path.write_bytes(b"\x00garbage that is no mesh at all\n")
    _refused(capsys, ["info", str(path)], f"junk{suffix}")
