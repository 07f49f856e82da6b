"""`shellvox info --json` on every real mesh reports the README's colour kind and closure."""

from __future__ import annotations

import json

import pytest

from shellvox.cli import main

# (file, colour carried, closed) from ../shared/meshes/README.md
README_TABLE = [
    ("spot/spot_triangulated.obj", "texture", 5856),
    ("duck/Duck.glb", "texture", 4212),
    ("box-textured/BoxTextured.glb", "texture", 12),
    ("airplane/colored_airplane.ply", "vertex", 10796),
    ("cube-vertexcolor/cube_with_vertexcolors.obj", "vertex", 12),
    ("3mf/rhombicuboctahedron_color.3mf", "face", 44),
    ("3mf/pyramid_vertexcolor.3mf", "vertex", 4),
    ("3mf/box.3mf", "none", 12),
    ("bunny/bunny.obj", "none", 3674),
]


@pytest.mark.parametrize(("name", "kind", "faces"), README_TABLE)
def test_info_json_matches_readme(shared_mesh, capsys, name, kind, faces):
    assert main(["info", "--json", str(shared_mesh(name))]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["colour"] == kind
    assert summary["closed"] is True and summary["oriented"] is True
    assert summary["faces"] == faces
    assert summary["volume_mm3"] > 0
    assert {"vertices", "bounds_mm"} <= summary.keys()


def test_3mf_sizes_are_millimetres(shared_mesh, capsys):
    assert main(["info", "--json", str(shared_mesh("3mf/box.3mf"))]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["size_mm"] == pytest.approx([10.0, 20.0, 30.0])
    assert summary["volume_mm3"] == pytest.approx(6000.0)
