"""The failures the fuzz suite (:mod:`test_fuzz_loaders`) found, each as its smallest file.

Each file is written by hand; ``shellvox info`` must refuse it in one line (exit 2).
"""

from __future__ import annotations

import json

from builders import glb_chunks, gltf_parts

from pipeline.cli import main


def _refused(path, capsys, *needles):
    status = main(["info", str(path)])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1, err
    assert lines[0].startswith("shellvox: error: "), err
    for needle in needles:
        assert needle in lines[0], lines[0]


def test_vrml_nested_too_deep(tmp_path, capsys):
    path = tmp_path / "deep.wrl"
    path.write_text("#VRML V2.0 utf8\n" + "Group { children [ " * 5000 + "] }" * 5000 + "\n")
    _refused(path, capsys, "deep.wrl", "nests", "too deeply")


def test_gltf_json_nested_too_deep(tmp_path, capsys):
    document, binary = gltf_parts()
    document["extras"] = "@"
    text = json.dumps(document).replace('"@"', "[" * 100_000 + "]" * 100_000)
    (tmp_path / "deep.glb").write_bytes(glb_chunks(text.encode(), binary))
    _refused(tmp_path / "deep.glb", capsys, "deep.glb", "JSON too deeply")
    (tmp_path / "deep.gltf").write_text(text)
    _refused(tmp_path / "deep.gltf", capsys, "deep.gltf", "JSON too deeply")
