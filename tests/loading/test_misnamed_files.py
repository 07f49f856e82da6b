"""A file whose content is not its suffix's format is refused saying what it is.

Real bytes of other kinds (the shared meshes, images Pillow writes, meshes trimesh
exports, archives zipfile and gzip write, the Python interpreter's program file) are
renamed to each model suffix: the load is refused in one line naming the file, the
format expected and what the file is, and for a model format the suffix to give it. Files
of the expected format in the forms that look like something else (a binary STL whose
header starts "solid", a binary PLY, an OBJ with a byte order mark and Latin-1 bytes, an
OFF after a comment, a GLB named .gltf) and every shared mesh still load (the open
teapot is read and refused as open, as before).
"""

from __future__ import annotations

import gzip
import io
import struct
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import shared_path
from PIL import Image

from shellvox.cli import main
from shellvox.config import LoadOptions
from shellvox.errors import InputError
from shellvox.loading import FORMATS, load_model

#: The shared meshes and their face counts, as ../shared/meshes/README.md lists them.
SHARED = {
    "spot/spot_triangulated.obj": 5856,
    "duck/Duck.glb": 4212,
    "box-textured/BoxTextured.glb": 12,
    "airplane/colored_airplane.ply": 10796,
    "cube-vertexcolor/cube_with_vertexcolors.obj": 12,
    "3mf/rhombicuboctahedron_color.3mf": 44,
    "3mf/pyramid_vertexcolor.3mf": 4,
    "3mf/box.3mf": 12,
    "bunny/bunny.obj": 3674,
}
#: The open teapot: read, then refused as open (tests/cli/test_cli_errors.py).
OPEN = "teapot/teapot.obj"

VRML = b"""#VRML V2.0 utf8
Shape { geometry IndexedFaceSet {
  coord Coordinate { point [ 0 0 0, 1 0 0, 0 1 0, 0 0 1 ] }
  coordIndex [ 0 2 1 -1, 0 1 3 -1, 0 3 2 -1, 1 2 3 -1 ]
} }
"""
HTML = b"<!DOCTYPE html>\n<html><head><title>bunny.obj - download</title></head></html>\n"


def _image(kind: str) -> bytes:
    out = io.BytesIO()
    picture = Image.fromarray(np.arange(48, dtype=np.uint8).reshape(4, 4, 3))
    picture.save(out, format=kind)
    return out.getvalue()


def _box() -> trimesh.Trimesh:
    return trimesh.creation.box(extents=(10, 20, 30))


def _glb_json(glb: bytes) -> bytes:
    length, kind = struct.unpack_from("<I4s", glb, 12)
    assert kind == b"JSON"
    return glb[20 : 20 + length]


def _zip(names: dict[str, bytes]) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        for name, data in names.items():
            archive.writestr(name, data)
    return out.getvalue()


def _kinds() -> dict[str, tuple[bytes, str]]:
    """Each kind: its real bytes and the words that name it."""
    bunny = shared_path("bunny/bunny.obj").read_bytes()
    duck = shared_path("duck/Duck.glb").read_bytes()
    box = _box()
    return {
        "png": (shared_path("spot/spot_texture.png").read_bytes(), "a PNG image"),
        "jpeg": (_image("JPEG"), "a JPEG image"),
        "gif": (_image("GIF"), "a GIF image"),
        "tiff": (_image("TIFF"), "a TIFF image"),
        "webp": (_image("WEBP"), "a WebP image"),
        "pdf": (_image("PDF"), "a PDF document"),
        "zip": (_zip({"readme.txt": b"hello\n"}), "a zip archive"),
        "zipped obj": (_zip({"bunny.obj": bunny}), "'bunny.obj'"),
        "gzip obj": (gzip.compress(bunny), "gzip-compressed"),
        "elf": (Path(sys.executable).resolve().read_bytes()[:65536], "ELF executable"),
        "html": (HTML, "an HTML page"),
        "utf-16 obj": (bunny.decode("latin-1").encode("utf-16"), "UTF-16 text"),
        "utf-16-le obj": (bunny.decode("latin-1").encode("utf-16-le"), "UTF-16 text"),
        "mtl": (shared_path("spot/spot.mtl").read_bytes(), "MTL material library"),
        "obj": (bunny, "an OBJ"),
        "glb": (duck, "a GLB"),
        "gltf": (_glb_json(duck), "a glTF (JSON)"),
        "ply": (shared_path("airplane/colored_airplane.ply").read_bytes(), "a PLY"),
        "3mf": (shared_path("3mf/box.3mf").read_bytes(), "a 3MF package"),
        "binary stl": (box.export(file_type="stl"), "binary STL of 12 triangles"),
        "ascii stl": (box.export(file_type="stl_ascii").encode(), "an ASCII STL"),
        "off": (box.export(file_type="off").encode(), "an OFF"),
        "wrl": (VRML, "a VRML 2.0 file"),
    }


#: The suffix of each kind that is a model format shellvox reads.
OWN = {
    "obj": ".obj", "glb": ".glb", "gltf": ".gltf", "ply": ".ply", "3mf": ".3mf",
    "binary stl": ".stl", "ascii stl": ".stl", "off": ".off", "wrl": ".wrl",
}  # fmt: skip
KINDS = [
    "png", "jpeg", "gif", "tiff", "webp", "pdf", "zip", "zipped obj", "gzip obj", "elf",
    "html", "utf-16 obj", "utf-16-le obj", "mtl", *OWN,
]  # fmt: skip
#: The kinds each suffix's reader takes (a glTF reader reads GLB and JSON alike).
READ_AS = {".gltf": {".gltf", ".glb"}, ".glb": {".gltf", ".glb"}}
CASES = [
    (suffix, kind)
    for suffix in sorted(FORMATS)
    for kind in KINDS
    if OWN.get(kind) not in READ_AS.get(suffix, {suffix})
    and not (suffix == ".3mf" and kind.startswith("zip"))  # a zip is read as a 3MF package
]


@pytest.fixture(scope="module")
def kinds():
    return _kinds()


def test_every_kind_is_tested(kinds):
    assert set(kinds) == set(KINDS)


@pytest.mark.parametrize(("suffix", "kind"), CASES, ids=[f"{k} as {s}" for s, k in CASES])
def test_another_kind_renamed_is_named(suffix, kind, kinds, tmp_path):
    data, words = kinds[kind]
    own = OWN.get(kind)
    path = tmp_path / f"model{suffix}"
    path.write_bytes(data)
    with pytest.raises(InputError) as caught:
        load_model(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: is not "), message
    assert words in message, message
    if own is not None:
        assert message.endswith(f"; rename it {own}"), message


@pytest.mark.parametrize("suffix", [".obj", ".off", ".wrl", ".ply", ".glb", ".gltf", ".3mf"])
def test_binary_data_where_text_or_a_signature_is_expected(suffix, tmp_path):
    path = tmp_path / f"noise{suffix}"
    noise = np.random.default_rng(7).integers(0, 256, 3000, dtype=np.uint8).tobytes()
    path.write_bytes(b"\x01\x02" + noise)  # no signature starts with these bytes
    starts = r"it is binary data (without .+ )?\(it starts 01 02 "
    with pytest.raises(InputError, match=rf"^\S+noise\.\w+: is not .+: {starts}"):
        load_model(path)


def test_text_with_binary_bytes_where_text_is_expected(tmp_path):
    text = shared_path("cube-vertexcolor/cube_with_vertexcolors.obj").read_bytes()
    path = tmp_path / "mixed.obj"
    path.write_bytes(text[:100] + bytes(200) + text[100:])
    with pytest.raises(
        InputError, match=r"it is text with binary bytes in it \(the first at byte 100\)"
    ):
        load_model(path)


@pytest.mark.parametrize("suffix", [".stl", ".ply", ".3mf"])
def test_text_where_binary_or_a_header_is_expected(suffix, tmp_path):
    path = tmp_path / f"notes{suffix}"
    path.write_text("Printed at 0.1 mm layers.\nSee the photos.\n")
    with pytest.raises(InputError) as caught:
        load_model(path)
    assert "it is text whose first line is 'Printed at 0.1 mm layers.'" in str(caught.value)


def test_the_command_line_says_it_in_one_line(tmp_path, capsys):
    path = tmp_path / "photo.obj"
    path.write_bytes(shared_path("spot/spot_texture.png").read_bytes())
    assert main(["info", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        f"shellvox: error: {path}: is not a text OBJ: it starts like a PNG image; give the "
        "model file (an image is read only as a texture that a model names)"
    ]


@pytest.mark.parametrize("relative", sorted(SHARED))
def test_every_shared_mesh_still_loads(relative):
    # scaled to fit, as a user would: the duck is 1.65 m long in its file (glTF: metres)
    loaded = load_model(shared_path(relative), LoadOptions(size_mm=50))
    assert len(loaded.faces) == SHARED[relative]


def test_the_open_teapot_is_read_and_refused_as_open():
    with pytest.raises(InputError, match="boundary edges"):
        load_model(shared_path(OPEN))


def _faces(path: Path, options: LoadOptions | None = None) -> int:
    return len(load_model(path, options).faces)


def test_a_binary_stl_whose_header_starts_with_solid_loads(tmp_path):
    data = bytearray(_box().export(file_type="stl"))
    data[:80] = b"solid box exported as binary".ljust(80, b" ")
    (tmp_path / "solid.stl").write_bytes(bytes(data))
    (tmp_path / "ascii.stl").write_text("\n  " + _box().export(file_type="stl_ascii"))
    assert _faces(tmp_path / "solid.stl") == _faces(tmp_path / "ascii.stl") == 12


def test_text_in_its_other_forms_loads(tmp_path):
    plain = shared_path("cube-vertexcolor/cube_with_vertexcolors.obj").read_bytes()
    bom = tmp_path / "bom.obj"
    bom.write_bytes(b"\xef\xbb\xbf# Mod\xe8le \xe9t\xe9 (Latin-1)\ng c\xf4t\xe9\n" + plain)
    assert _faces(bom) == _faces(shared_path("cube-vertexcolor/cube_with_vertexcolors.obj"))
    off = tmp_path / "commented.off"
    off.write_bytes(b"# exported\n\n" + _box().export(file_type="off").encode())
    assert _faces(off) == 12
    glb = tmp_path / "duck.gltf"
    glb.write_bytes(shared_path("duck/Duck.glb").read_bytes())
    fit = LoadOptions(size_mm=50)  # the duck is 1.65 m long (glTF: metres)
    assert _faces(glb, fit) == _faces(shared_path("duck/Duck.glb"), fit)
