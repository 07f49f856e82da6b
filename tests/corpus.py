"""A corpus of small broken or awkward model files, written from the format specifications.

Each case is built into its own folder by :func:`build`; the test says what must happen:
an ``InputError`` (one line, exit 2) or a ``ShellvoxWarning`` (one line, exit 0). The
builders write bytes by hand (JSON, XML, zip, PNG chunks) so that they do not depend on
the loaders under test.
"""

from __future__ import annotations

import base64
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
    MATERIAL_NS,
    TET_FACES,
    TET_VERTICES,
    marker_image,
    png_bytes,
    write_3mf,
)

# Per-corner UVs of the tetrahedron's 12 unshared corners (v up, OBJ convention).
CORNER_UV = np.tile(np.array([[0.05, 0.05], [0.95, 0.05], [0.05, 0.95]]), (4, 1, 1))
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


def obj_two_libraries_one_missing(folder: Path) -> Path:
    text = obj_text(uv=False).replace("mtllib model.mtl", "mtllib model.mtl\nmtllib gone.mtl")
    (folder / "model.obj").write_text(text)
    (folder / "model.mtl").write_text("newmtl painted\nKd 1 0 0\n")
    return folder / "model.obj"


# ---------------------------------------------------------------------------- glTF


def gltf_parts(
    *,
    image: dict | None = None,
    factor: list | None = None,
    tex_coord: int = 0,
    texture_extensions: dict | None = None,
) -> tuple[dict, bytes]:
    """glTF document and binary buffer of the tetrahedron (12 corners), UVs, one material.

    ``image`` is the glTF image object (``{"uri": ...}``), or None for no texture.
    """
    positions = TET_VERTICES[TET_FACES].reshape(-1, 3).astype(np.float32)
    uv = CORNER_UV.reshape(-1, 2).astype(np.float32).copy()
    uv[:, 1] = 1.0 - uv[:, 1]  # glTF: v grows down from the top-left
    indices = np.arange(12, dtype=np.uint32)
    blobs = [positions.tobytes(), uv.tobytes(), indices.tobytes()]
    views, binary = [], b""
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(blob)})
        binary += blob + b"\0" * (-len(blob) % 4)
    pbr: dict = {}
    if factor is not None:
        pbr["baseColorFactor"] = factor
    document: dict = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": views,
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 12,
                "type": "VEC3",
                "min": positions.min(0).tolist(),
                "max": positions.max(0).tolist(),
            },
            {"bufferView": 1, "componentType": 5126, "count": 12, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": 12, "type": "SCALAR"},
        ],
        "materials": [{"name": "painted", "pbrMetallicRoughness": pbr}],
        "meshes": [
            {
                "primitives": [
                    {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}
                ]
            }
        ],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    if image is not None:
        info: dict = {"index": 0, "texCoord": tex_coord}
        if texture_extensions:
            info["extensions"] = texture_extensions
        pbr["baseColorTexture"] = info
        document["images"] = [image]
        document["textures"] = [{"source": 0}]
    return document, binary


def glb_bytes(document: dict, binary: bytes) -> bytes:
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text
    body += struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


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


def embed_image(data: bytes) -> Callable[[dict, bytes], tuple[dict, bytes]]:
    """Edit: append ``data`` to the buffer as the material's image."""

    def edit(document: dict, binary: bytes) -> tuple[dict, bytes]:
        document["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)}
        )
        binary += data + b"\0" * (-len(data) % 4)
        document["buffers"][0]["byteLength"] = len(binary)
        document["images"] = [{"bufferView": 3, "mimeType": "image/png"}]
        return document, binary

    return edit


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


def gltf_data_uri_image(folder: Path) -> Path:
    uri = "data:image/png;base64," + base64.b64encode(png_bytes(IMAGE)).decode()
    return write_gltf(folder, *gltf_parts(image={"uri": uri}))


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


# ---------------------------------------------------------------------------- the corpus

TEX = png_bytes(IMAGE)
BIG = png_header_only(13000, 13000)
MTL_TEX = "newmtl painted\nKd 1 1 1\nmap_Kd tex.png\n"

CASES = [
    # OBJ + MTL
    Case(
        "obj texture outside the folder",
        obj_outside_texture,
        "error",
        ("x.png", "outside the model's folder", "--texture FILE", "--force"),
    ),
    Case(
        "obj texture outside the folder, --force",
        obj_outside_texture,
        "warning",
        ("x.png", "outside the model's folder", "--force"),
        ("--force",),
    ),
    Case("obj absolute texture path", obj_absolute_texture, "error", ("secret.png", "outside")),
    Case("obj mtllib outside the folder", obj_outside_mtl, "error", ("lib.mtl", "outside")),
    Case(
        "obj texture without vt",
        obj_with(MTL_TEX, image=TEX, uv=False),
        "warning",
        ("'painted'", "texture coordinates", "Kd"),
    ),
    Case(
        "obj --texture without vt",
        obj_with("newmtl painted\nKd 1 0 0\n", image=TEX, uv=False),
        "error",
        ("--texture", "texture coordinates"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj --texture not used",
        obj_with(MTL_TEX, image=TEX),
        "warning",
        ("--texture", "not used", "found"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj --texture on a model without map_Kd",
        obj_with("newmtl painted\nKd 1 0 0\n", image=TEX),
        "warning",
        ("--texture", "not used", "no map_Kd"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj usemtl not in the MTL",
        obj_with("newmtl other\nKd 1 0 0\n", material="painted"),
        "warning",
        ("'painted'", "not defined", "white"),
    ),
    Case(
        "obj malformed Kd",
        obj_with("newmtl painted\nKd 1 zero 0\n", uv=False),
        "error",
        ("model.mtl", "'painted'", "Kd", "1 zero 0"),
    ),
    Case(
        "obj Kd spectral",
        obj_with("newmtl painted\nKd spectral red.rfl\n", uv=False),
        "warning",
        ("'painted'", "spectral", "white"),
    ),
    Case(
        "obj map_Kd offset option",
        obj_with("newmtl painted\nmap_Kd -o 0.5 0.25 tex.png\n", image=TEX),
        "warning",
        ("-o 0.5 0.25", "not applied"),
    ),
    Case(
        "obj vertex colours beside a texture",
        obj_with(MTL_TEX, image=TEX, colours=True),
        "warning",
        ("vertex colours", "ignored"),
    ),
    Case(
        "obj one of two MTLs missing",
        obj_two_libraries_one_missing,
        "warning",
        ("gone.mtl", "missing"),
    ),
    Case(
        "obj texture of 13000 x 13000 pixels",
        obj_with(MTL_TEX, image=BIG),
        "error",
        ("13000x13000", "169,000,000 pixels", "--force"),
    ),
    Case(
        "obj texture of 20000 x 20000 pixels (past Pillow's bomb limit)",
        obj_with(MTL_TEX, image=png_header_only(20000, 20000)),
        "error",
        ("20000x20000", "--force"),
    ),
    Case(
        "obj truncated texture",
        obj_with(MTL_TEX, image=TEX[: len(TEX) // 2]),
        "error",
        ("tex.png", "unreadable", "--colour"),
    ),
    Case(
        "obj missing texture with --colour",
        obj_with("newmtl painted\nmap_Kd gone.png\n"),
        "warning",
        ("gone.png", "missing", "--colour 9,8,7"),
        ("--colour", "9,8,7"),
    ),
    Case("obj coordinate 1e300", obj_coordinates("1e300"), "error", ("far.obj", "1e+300 mm")),
    Case("obj coordinate 2e6", obj_coordinates("2e6"), "error", ("far.obj", "--force")),
    Case("obj coordinate inf", obj_coordinates("inf"), "error", ("far.obj", "infinite")),
    Case("obj coordinate nan", obj_coordinates("nan"), "error", ("far.obj", "NaN")),
    Case(
        "obj --scale overflowing to infinity",
        obj_coordinates("1e300"),
        "error",
        ("--scale", "infinity"),
        ("--scale", "1e10", "--force"),
    ),
    # glTF / GLB
    Case(
        "gltf image missing",
        gltf_image("gone.png"),
        "error",
        ("model.gltf", "'gone.png'", "missing", "--colour"),
    ),
    Case(
        "gltf image missing with --colour",
        gltf_image("gone.png"),
        "warning",
        ("'gone.png'", "missing", "--colour 10,20,30"),
        ("--colour", "10,20,30"),
    ),
    Case(
        "gltf image unreadable",
        gltf_image("bad.png", data=b"not an image at all"),
        "error",
        ("'bad.png'", "unreadable"),
    ),
    Case(
        "gltf image outside the folder",
        gltf_image("../secret.png", data=TEX, where="secret.png"),
        "error",
        ("'../secret.png'", "outside the model's folder", "--force"),
    ),
    Case(
        "gltf image by absolute path",
        gltf_image("FOLDER/secret.png", data=TEX, where="secret.png"),
        "error",
        ("secret.png", "outside the model's folder"),
    ),
    Case(
        "gltf image remote",
        gltf_image("https://example.com/x.png"),
        "error",
        ("remote URI", "download"),
    ),
    Case(
        "glb buffer declaring 1e12 bytes",
        glb_with(set_key(("buffers", 0, "byteLength"), 10**12)),
        "error",
        ("1,000,000,000,000 bytes", "BIN chunk"),
    ),
    Case(
        "glb bufferView past the buffer",
        glb_with(set_key(("bufferViews", 1, "byteLength"), 10**6)),
        "error",
        ("bufferView 1", "past the end"),
    ),
    Case(
        "glb accessor past its bufferView",
        glb_with(set_key(("accessors", 0, "count"), 10**6)),
        "error",
        ("accessor 0", "bufferView 0"),
    ),
    Case(
        "glb data-less accessor of 1e12 items",
        glb_with(
            set_key(("accessors", 1), {"componentType": 5126, "count": 10**12, "type": "VEC2"})
        ),
        "error",
        ("accessor 1", "--force"),
    ),
    Case(
        "glb embedded texture of 13000 x 13000 pixels",
        glb_with(embed_image(BIG), image={}),
        "error",
        ("13000x13000", "--force"),
    ),
    Case(
        "glb malformed baseColorFactor",
        glb_with(lambda d, b: (d, b), factor=["red", 0, 0, 1]),
        "error",
        ("'painted'", "baseColorFactor"),
    ),
    Case(
        "glb texture on TEXCOORD_1",
        glb_with(embed_image(TEX), image={}, tex_coord=1),
        "warning",
        ("'painted'", "TEXCOORD_1", "baseColorFactor"),
    ),
    Case(
        "glb malformed KHR_texture_transform",
        glb_with(
            embed_image(TEX),
            image={},
            texture_extensions={"KHR_texture_transform": {"scale": [2, "x"]}},
        ),
        "error",
        ("'painted'", "KHR_texture_transform scale", "2 numbers"),
    ),
    Case("glb truncated", truncated_glb, "error", ("cut.glb", "truncated")),
    Case(
        "glb with --texture",
        glb_with(embed_image(TEX), image={}),
        "warning",
        ("--texture applies to OBJ files only", "model.glb"),
        ("--texture", "FOLDER/model.glb"),  # any existing file: it is never read
    ),
    Case(
        "glb with a string where a material belongs",
        glb_with(set_key(("materials", 0), "painted")),
        "error",
        ("model.glb", "malformed glTF document"),
    ),
    Case(
        "glb primitive with a material index out of range",
        glb_with(set_key(("meshes", 0, "primitives", 0, "material"), 7)),
        "error",
        ("model.glb", "malformed glTF document"),
    ),
    Case("gltf buffer file missing", gltf_missing_buffer, "error", ("'gone.bin'", "missing")),
    Case(
        "gltf buffer outside the folder",
        gltf_outside_buffer,
        "error",
        ("'../outside.bin'", "outside the model's folder"),
    ),
    # 3MF
    Case("3mf broken _rels/.rels", threemf(model_xml(), rels="<Rel"), "error", ("_rels/.rels",)),
    Case("3mf bad CRC", threemf_bad_crc, "error", ("3D/3dmodel.model", "corrupt")),
    Case(
        "3mf bad colour",
        threemf(model_xml(colour="#GGHHII")),
        "error",
        ("'#GGHHII'", "#RRGGBB"),
    ),
    Case(
        "3mf transform of 11 numbers",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 1 0 0")),
        "error",
        ("malformed transform", "12 numbers"),
    ),
    Case(
        "3mf non-numeric transform",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 one 0 0 0")),
        "error",
        ("malformed transform",),
    ),
    Case(
        "3mf singular transform",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 0 0 0 0")),
        "error",
        ("singular transform",),
    ),
    Case(
        "3mf non-numeric vertex coordinate",
        threemf(model_xml(vertex='x="zero" y="0" z="0"')),
        "error",
        ("vertex coordinate", "'zero'"),
    ),
    Case(
        "3mf infinite vertex coordinate",
        threemf(model_xml(vertex='x="inf" y="0" z="0"')),
        "error",
        ("m.3mf", "infinite"),
    ),
    Case("3mf unknown texid", threemf_unknown_texid, "error", ("'99'", "unknown texture")),
    Case(
        "3mf composite materials",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<m:compositematerials id="5" matid="2" matindices="0">'
                '<m:composite values="1"/></m:compositematerials><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="5" p1="0"')
        ),
        "error",
        ("composite materials '5'", "unknown base materials '2'"),
    ),
    Case(
        "3mf composite materials of base materials",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<basematerials id="3"><base name="a" displaycolor="#FF0000"/>'
                '<base name="b" displaycolor="#0000FF"/></basematerials>'
                '<m:compositematerials id="5" matid="3" matindices="0 1">'
                '<m:composite values="1 3"/></m:compositematerials><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="5" p1="0"')
        ),
        "warning",
        ("compositematerials", "display colour", "no per-face material ratios"),
    ),
    Case(
        "3mf multiproperties with a malformed blend method",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<m:multiproperties id="6" pids="2 2" blendmethods="screen">'
                '<m:multi pindices="0 0"/></m:multiproperties><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="6" p1="0"')
        ),
        "error",
        ("multiproperties '6'", "blendmethods", "'screen'"),
    ),
    Case(
        "3mf p:path to a missing model part",
        threemf(
            model_xml().replace(
                '<build><item objectid="1"/>',
                '<build><item objectid="1" p:path="/3D/Objects/gone.model" '
                'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06"/>',
            )
        ),
        "error",
        ("p:path", "'/3D/Objects/gone.model'"),
    ),
    Case(
        "3mf texture missing from the package",
        threemf_missing_texture,
        "error",
        ("gone.png", "missing", "--colour"),
    ),
    Case(
        "3mf texture missing, --colour",
        threemf_missing_texture,
        "warning",
        ("gone.png", "missing", "--colour 1,2,3"),
        ("--colour", "1,2,3"),
    ),
    # PLY
    Case(
        "ply TextureFile missing",
        ply_with("gone.png"),
        "error",
        ("model.ply", "'gone.png'", "missing", "--colour"),
    ),
    Case(
        "ply TextureFile outside the folder",
        ply_with("../tex.png", image=TEX, where="tex.png"),
        "error",
        ("'../tex.png'", "outside the model's folder"),
    ),
    Case(
        "ply TextureFile without texture coordinates",
        ply_with("tex.png", image=TEX, uv=False),
        "warning",
        ("'tex.png'", "no texture coordinates"),
    ),
    Case(
        "ply colour properties trimesh does not read",
        ply_with(None, uv=False, extra="diffuse_red diffuse_green diffuse_blue"),
        "warning",
        ("diffuse_red", "not read as colour"),
    ),
    # STL
    Case("stl random bytes", random_stl, "error", ("blob.stl", "not a valid STL")),
]
