"""The failures the fuzz suite (:mod:`test_fuzz_loaders`) found, each as its smallest file.

Each file is written by hand; ``shellvox info`` must refuse it in one line (exit 2).
"""

from __future__ import annotations

import json
import struct
import time

import pytest
from builders import glb_bytes, glb_chunks, gltf_parts
from corpus_files import RELS, model_xml, obj_text, ply_text, threemf, write_gltf

from shellvox.cli import main
from shellvox.loading.vrml import parse_vrml


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
    _refused(path, capsys, "m.3mf", "out of range (beyond 64 bits)")


LONG = "a" * 5000 + ".png"  # past NAME_MAX: looking it up fails with ENAMETOOLONG
SHAPE = (
    "geometry IndexedFaceSet { coord Coordinate { point [0 0 0, 10 0 0, 0 10 0, 0 0 10] } "
    "coordIndex [0 2 1 -1 0 1 3 -1 0 3 2 -1 1 2 3 -1] "
    "texCoord TextureCoordinate { point [0 0, 1 0, 0 1, 1 1] } }"
)


def _long_names(folder, where):
    if where == "mtllib":
        (folder / "m.obj").write_text(obj_text().replace("model.mtl", LONG))
    elif where == "map_Kd":
        (folder / "m.obj").write_text(obj_text())
        (folder / "model.mtl").write_text(f"newmtl painted\nmap_Kd {LONG}\n")
    elif where == "TextureFile":
        (folder / "m.ply").write_text(ply_text(texture_file=LONG))
    elif where == "buffer":
        document, _ = gltf_parts()
        document["buffers"][0]["uri"] = LONG
        (folder / "m.gltf").write_text(json.dumps(document))
    elif where == "image":
        write_gltf(folder, *gltf_parts(image={"uri": LONG}), name="m.gltf")
    else:
        texture = f'appearance Appearance {{ texture ImageTexture {{ url "{LONG}" }} }}'
        (folder / "m.wrl").write_text(f"#VRML V2.0 utf8\nShape {{ {texture} {SHAPE} }}\n")
    return next(folder.glob("m.*"))


@pytest.mark.parametrize("where", ["mtllib", "map_Kd", "TextureFile", "buffer", "image", "url"])
def test_referenced_name_too_long(tmp_path, capsys, where):
    _refused(_long_names(tmp_path, where), capsys, "aaaa.png'", "missing")


def _nested_scene(depth: int, comment_chars: int) -> str:
    opened = "Group { children [\n" * depth
    return f"#VRML V2.0 utf8\n{opened}# {'x' * comment_chars}\n{SHAPE_NODE}\n" + "] }\n" * depth


SHAPE_NODE = f"Shape {{ {SHAPE} }}"


def test_vrml_nested_lists_parse_in_linear_time(tmp_path):
    """Each list scanned on to the next ']' (and its comments removed) made nested
    lists quadratic: 150 groups around a 4 MB comment took 150 scans of it."""
    times = []
    for depth in (1, 150):
        text = _nested_scene(depth, 4_000_000)
        started = time.perf_counter()
        scene = parse_vrml(tmp_path / "deep.wrl", text)
        times.append(time.perf_counter() - started)
        assert len(scene.nodes) == 1
    assert times[1] < 10 * times[0] + 0.5, times


def test_3mf_zip_version_too_new(tmp_path, capsys):
    path = threemf(model_xml())(tmp_path)
    data = bytearray(path.read_bytes())
    at = data.index(b"PK\x01\x02") + 6  # the central directory's "version needed to extract"
    data[at : at + 2] = struct.pack("<H", 255)
    path.write_bytes(bytes(data))
    _refused(path, capsys, "m.3mf", "cannot be read", "zip file version 25.5")


@pytest.mark.parametrize(
    "transform", ["1 0 0 0 1 0 -1e308 0 1 5 6 7", "1e300 0 0 0 1 0 0 0 1 0 0 0"]
)
def test_3mf_transform_of_1e308(tmp_path, capsys, transform):
    path = threemf(model_xml(transform=transform))(tmp_path)
    _refused(path, capsys, "m.3mf", f"singular transform {transform!r}")
