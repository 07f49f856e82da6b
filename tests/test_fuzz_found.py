"""The failures the fuzz suite (:mod:`test_fuzz_loaders`) found, each as its smallest file.

Each file is written by hand; ``shellvox info`` must refuse it in one line (exit 2).
"""

from __future__ import annotations

import json
import struct

import pytest
from builders import glb_bytes, glb_chunks, gltf_parts
from corpus_files import RELS, model_xml, ply_text, threemf

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


@pytest.mark.parametrize("index", ["99", "-5"])
def test_ply_face_index_out_of_range(tmp_path, capsys, index):
    text = ply_text(texture_file=None, uv=False, extra="red green blue")
    (tmp_path / "far.ply").write_text(text.replace("3 9 10 11", f"3 9 10 {index}"))
    _refused(tmp_path / "far.ply", capsys, "far.ply", "vertex index out of range")


def test_gltf_index_out_of_range(tmp_path, capsys):
    document, binary = gltf_parts()
    view = document["bufferViews"][2]
    at = view["byteOffset"] + view["byteLength"] - 4
    binary = binary[:at] + struct.pack("<I", 1000) + binary[at + 4 :]
    (tmp_path / "far.glb").write_bytes(glb_bytes(document, binary))
    _refused(tmp_path / "far.glb", capsys, "far.glb", "vertex index out of range")


@pytest.mark.parametrize("entry", ["model", "rels"])
def test_3mf_unknown_xml_encoding(tmp_path, capsys, entry):
    model, rels = model_xml(), RELS
    if entry == "model":
        model = model.replace('encoding="UTF-8"', 'encoding="UTF0"')
    else:
        rels = rels.replace('encoding="UTF-8"', 'encoding="UTF0"')
    path = threemf(model, rels)(tmp_path)
    _refused(path, capsys, "m.3mf", "malformed", "UTF0")


@pytest.mark.parametrize(
    ("old", "new"),
    [('v3="1"', 'v3="99999999999999999999"'), ('p1="0"', 'p1="-99999999999999999999"')],
)
def test_3mf_integer_past_int64(tmp_path, capsys, old, new):
    path = threemf(model_xml().replace(old, new, 1))(tmp_path)
    _refused(path, capsys, "m.3mf", "too large for a 64-bit integer", new.split('"')[1][:27])
