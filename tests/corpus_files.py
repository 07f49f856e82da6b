"""Builders of the corpus's small broken or awkward model files (see :mod:`corpus`).

They write bytes by hand (JSON, XML, zip, PNG chunks) from the format specifications, so
that they do not depend on the loaders under test.
"""

from __future__ import annotations

import json
import struct
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from builders import (
    CORE_NS,
    CORNER_UV,
    MATERIAL_NS,
    TET_FACES,
    TET_VERTICES,
    glb_bytes,
    gltf_parts,
    marker_image,
    png_bytes,
    write_3mf,
)

IMAGE = marker_image(16, 8, 2, 3)


@dataclass(frozen=True)
class Case:
    """One corpus file and what loading it must give."""

    name: str
    build: Callable[[Path], Path]  # writes the files into a folder, returns the model
    outcome: str  # "error" or "warning"
    needles: tuple[str, ...]  # words the one line must contain
    options: tuple[str, ...] = field(default=())  # extra CLI options; FOLDER is the folder


# ---------------------------------------------------------------------------- images


def png_header_only(width: int, height: int) -> bytes:
    """A PNG whose header declares ``width x height`` RGBA pixels, with almost no data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0" * 16))
        + chunk(b"IEND", b"")
    )


# ---------------------------------------------------------------------------- OBJ


def obj_text(*, uv: bool = True, material: str = "painted", colours: bool = False) -> str:
    """The tetrahedron as OBJ text with ``mtllib model.mtl`` and one material."""
    lines = ["mtllib model.mtl"]
    for x, y, z in TET_VERTICES:
        lines.append(f"v {x} {y} {z}" + (" 0.2 0.4 0.6" if colours else ""))
    if uv:
        lines += [f"vt {u} {v}" for u, v in CORNER_UV.reshape(-1, 2)]
    lines.append(f"usemtl {material}")
    for i, face in enumerate(TET_FACES):
        corners = (f"{v + 1}/{3 * i + c + 1}" if uv else f"{v + 1}" for c, v in enumerate(face))
        lines.append("f " + " ".join(corners))
    return "\n".join(lines) + "\n"


def obj_with(
    mtl: str, *, image: bytes | None = None, image_name: str = "tex.png", **kw
) -> Callable:
    """Builder of an OBJ + ``model.mtl`` (+ an image beside them)."""

    def build(folder: Path) -> Path:
        (folder / "model.obj").write_text(obj_text(**kw))
        (folder / "model.mtl").write_text(mtl)
        if image is not None:
            (folder / image_name).write_bytes(image)
        return folder / "model.obj"

    return build


def obj_outside_texture(folder: Path) -> Path:
    """``map_Kd ../../secret/x.png``: a real image two folders up."""
    model = folder / "a" / "b"
    model.mkdir(parents=True)
    (folder / "secret").mkdir()
    (folder / "secret" / "x.png").write_bytes(png_bytes(IMAGE))
    (model / "model.obj").write_text(obj_text())
    (model / "model.mtl").write_text("newmtl painted\nmap_Kd ../../secret/x.png\n")
    return model / "model.obj"


def obj_absolute_texture(folder: Path) -> Path:
    """``map_Kd /abs/.../secret.png`` outside the model's folder."""
    (folder / "m").mkdir()
    secret = folder / "secret.png"
    secret.write_bytes(png_bytes(IMAGE))
    (folder / "m" / "model.obj").write_text(obj_text())
    (folder / "m" / "model.mtl").write_text(f"newmtl painted\nmap_Kd {secret}\n")
    return folder / "m" / "model.obj"


def obj_outside_mtl(folder: Path) -> Path:
    (folder / "m").mkdir()
    (folder / "lib.mtl").write_text("newmtl painted\nKd 1 0 0\n")
    (folder / "m" / "model.obj").write_text(obj_text().replace("model.mtl", "../lib.mtl"))
    return folder / "m" / "model.obj"


def obj_coordinates(value: str) -> Callable:
    def build(folder: Path) -> Path:
        lines = [f"v {x} {y} {z}" for x, y, z in TET_VERTICES]
        lines[1] = f"v {value} 0 0"
        lines += ["f " + " ".join(str(v + 1) for v in face) for face in TET_FACES]
        (folder / "far.obj").write_text("\n".join(lines) + "\n")
        return folder / "far.obj"

    return build


def obj_face(line: str) -> Callable:
    """A tetrahedron OBJ whose last face line is `line` (one ``vt``, used by every face
    when `line` has one)."""

    def build(folder: Path) -> Path:
        lines = [f"v {x} {y} {z}" for x, y, z in TET_VERTICES] + ["vt 0 0"]
        slash = "/1" if "/" in line else ""
        lines += ["f " + " ".join(f"{v + 1}{slash}" for v in face) for face in TET_FACES[:3]]
        (folder / "index.obj").write_text("\n".join([*lines, line]) + "\n")
        return folder / "index.obj"

    return build


def obj_two_libraries_one_missing(folder: Path) -> Path:
    text = obj_text(uv=False).replace("mtllib model.mtl", "mtllib model.mtl\nmtllib gone.mtl")
    (folder / "model.obj").write_text(text)
    (folder / "model.mtl").write_text("newmtl painted\nKd 1 0 0\n")
    return folder / "model.obj"


# ---------------------------------------------------------------------------- glTF


def write_gltf(folder: Path, document: dict, binary: bytes, name: str = "model.gltf") -> Path:
    """A ``.gltf`` with its buffer as ``model.bin`` beside it (unless the document says)."""
    document = json.loads(json.dumps(document))
    document["buffers"][0].setdefault("uri", "model.bin")
    if document["buffers"][0]["uri"] == "model.bin":
        (folder / "model.bin").write_bytes(binary)
    (folder / name).write_text(json.dumps(document))
    return folder / name


def gltf_image(uri: str, *, data: bytes | None = None, where: str = "") -> Callable:
    """A ``.gltf`` whose image has ``uri``; ``data`` is written at ``where`` (or the uri)."""

    def build(folder: Path) -> Path:
        model = folder / "m"
        model.mkdir()
        target = uri.replace("FOLDER", str(folder))
        if data is not None:
            file = folder / where if where else model / target
            file.parent.mkdir(parents=True, exist_ok=True)
            file.write_bytes(data)
        return write_gltf(model, *gltf_parts(image={"uri": target}))

    return build


def glb_with(edit: Callable[[dict, bytes], tuple[dict, bytes]], **kw) -> Callable:
    """A GLB of :func:`gltf_parts` after ``edit(document, binary)``."""

    def build(folder: Path) -> Path:
        document, binary = edit(*gltf_parts(**kw))
        (folder / "model.glb").write_bytes(glb_bytes(document, binary))
        return folder / "model.glb"

    return build


def set_key(path: tuple, value) -> Callable[[dict, bytes], tuple[dict, bytes]]:
    """Edit: set ``document[path[0]][path[1]]... = value``."""

    def edit(document: dict, binary: bytes) -> tuple[dict, bytes]:
        node = document
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
        return document, binary

    return edit


def truncated_glb(folder: Path) -> Path:
    data = glb_bytes(*gltf_parts())
    (folder / "cut.glb").write_bytes(data[: len(data) - 40])
    return folder / "cut.glb"


def gltf_missing_buffer(folder: Path) -> Path:
    document, _ = gltf_parts()
    document["buffers"][0]["uri"] = "gone.bin"
    return write_gltf(folder, document, b"")


def gltf_outside_buffer(folder: Path) -> Path:
    document, binary = gltf_parts()
    (folder / "m").mkdir()
    (folder / "outside.bin").write_bytes(binary)
    document["buffers"][0]["uri"] = "../outside.bin"
    return write_gltf(folder / "m", document, binary)


# ---------------------------------------------------------------------------- 3MF


def model_xml(
    *, vertex: str = 'x="0" y="0" z="0"', colour: str = "#FF0000", transform: str | None = None
) -> str:
    """The tetrahedron's 3MF model part with a colour group and an optional transform."""
    vertices = [f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in TET_VERTICES]
    vertices[0] = f"<vertex {vertex}/>"
    triangles = "".join(
        f'<triangle v1="{a}" v2="{b}" v3="{c}" pid="2" p1="0"/>' for a, b, c in TET_FACES
    )
    item = f' transform="{transform}"' if transform is not None else ""
    return (
        f'<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xml:lang="en-US" '
        f'xmlns="{CORE_NS}" xmlns:m="{MATERIAL_NS}"><resources>'
        f'<m:colorgroup id="2"><m:color color="{colour}"/></m:colorgroup>'
        f'<object id="1" type="model"><mesh><vertices>{"".join(vertices)}</vertices>'
        f"<triangles>{triangles}</triangles></mesh></object></resources>"
        f'<build><item objectid="1"{item}/></build></model>'
    )


RELS = (
    '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.'
    'openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel'
    '.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/'
    '3dmodel"/></Relationships>'
)


def threemf(model: str, rels: str = RELS, stored: bool = False) -> Callable:
    def build(folder: Path) -> Path:
        method = zipfile.ZIP_STORED if stored else zipfile.ZIP_DEFLATED
        with zipfile.ZipFile(folder / "m.3mf", "w", method) as archive:
            archive.writestr("_rels/.rels", rels)
            archive.writestr("3D/3dmodel.model", model)
        return folder / "m.3mf"

    return build


def threemf_bad_crc(folder: Path) -> Path:
    path = threemf(model_xml(), stored=True)(folder)
    data = bytearray(path.read_bytes())
    at = data.index(b'xml:lang="en-US"')
    data[at + 10 : at + 12] = b"fr"  # still well-formed XML, but the CRC-32 no longer matches
    path.write_bytes(bytes(data))
    return path


def threemf_unknown_texid(folder: Path) -> Path:
    write_3mf(folder / "t.3mf", texture=IMAGE, corner_uv=CORNER_UV)
    return _rewrite_model(folder / "t.3mf", b'texid="3"', b'texid="99"')


def threemf_missing_texture(folder: Path) -> Path:
    write_3mf(folder / "t.3mf", texture=IMAGE, corner_uv=CORNER_UV)
    return _rewrite_model(folder / "t.3mf", b"/3D/Textures/tex.png", b"/3D/Textures/gone.png")


def _rewrite_model(path: Path, old: bytes, new: bytes) -> Path:
    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    entries["3D/3dmodel.model"] = entries["3D/3dmodel.model"].replace(old, new)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in entries.items():
            archive.writestr(name, data)
    return path


# ---------------------------------------------------------------------------- PLY


def ply_text(*, texture_file: str | None, uv: bool = True, extra: str = "") -> str:
    """The tetrahedron (12 unshared corners) as ASCII PLY with per-vertex u, v."""
    positions = TET_VERTICES[TET_FACES].reshape(-1, 3)
    uvs = CORNER_UV.reshape(-1, 2)
    header = ["ply", "format ascii 1.0"]
    if texture_file is not None:
        header.append(f"comment TextureFile {texture_file}")
    header += ["element vertex 12", "property float x", "property float y", "property float z"]
    if uv:
        header += ["property float s", "property float t"]
    header += [f"property uchar {name}" for name in extra.split()]
    header += ["element face 4", "property list uchar int vertex_indices", "end_header"]
    rows = []
    for i, (x, y, z) in enumerate(positions):
        row = f"{x} {y} {z}" + (f" {uvs[i, 0]} {uvs[i, 1]}" if uv else "")
        rows.append(row + " 100" * len(extra.split()))
    rows += [f"3 {3 * f} {3 * f + 1} {3 * f + 2}" for f in range(4)]
    return "\n".join(header + rows) + "\n"


def ply_with(texture_file: str | None, image: bytes | None = None, where: str = "", **kw):
    def build(folder: Path) -> Path:
        (folder / "m").mkdir()
        (folder / "m" / "model.ply").write_text(ply_text(texture_file=texture_file, **kw))
        if image is not None:
            (folder / (where or f"m/{texture_file}")).write_bytes(image)
        return folder / "m" / "model.ply"

    return build


# ---------------------------------------------------------------------------- STL


def random_stl(folder: Path) -> Path:
    data = np.random.default_rng(3).integers(0, 256, 5000, dtype=np.uint8).tobytes()
    (folder / "blob.stl").write_bytes(data)
    return folder / "blob.stl"


# ---------------------------------------------------------------------------- shared data

TEX = png_bytes(IMAGE)
BIG = png_header_only(13000, 13000)
MTL_TEX = "newmtl painted\nKd 1 1 1\nmap_Kd tex.png\n"
