"""Hypothesis strategies of valid coloured models, one per format, for the loader fuzz suite.

Each strategy draws a :class:`Model`: the files of one valid model (the model file and
its companions: MTL, textures, glTF buffers; a 3MF's package entries before zipping) that
every loader must read (exit 0). :mod:`fuzz_mutate` then damages them. The text and
binary layouts are written here and in :mod:`builders` / :mod:`corpus_files` by hand from
the format specifications, independent of the loaders.
"""

from __future__ import annotations

import io
import json
import struct
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from builders import (
    CORE_NS,
    CORNER_UV,
    MATERIAL_NS,
    TET_FACES,
    TET_VERTICES,
    embed_image,
    glb_bytes,
    gltf_parts,
    marker_image,
    png_bytes,
)
from corpus_files import RELS, obj_text, ply_text
from hypothesis import strategies as st

PRODUCTION_NS = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
MODEL_ENTRY = "3D/3dmodel.model"
CORNERS = TET_VERTICES[TET_FACES].reshape(-1, 3)  # (12, 3) the unshared corners


@dataclass(frozen=True)
class Model:
    """The files of one model: ``files`` by name; a 3MF's package is ``entries`` until packed."""

    name: str  # the model file, e.g. "m.obj"
    files: dict[str, bytes]
    entries: dict[str, bytes] | None = field(default=None)

    def packed(self) -> Model:
        """The same model with its package entries zipped into the model file."""
        if self.entries is None:
            return self
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
            for name, data in self.entries.items():
                archive.writestr(name, data)
        return replace(self, files={**self.files, self.name: buffer.getvalue()}, entries=None)

    def write(self, folder: Path) -> Path:
        """Write every file into ``folder``; return the model's path."""
        for name, data in self.packed().files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(data)
        return folder / self.name


@st.composite
def textures(draw: st.DrawFn) -> bytes:
    """A small RGBA PNG with a marker pixel."""
    width, height = draw(st.integers(1, 16)), draw(st.integers(1, 16))
    row, col = draw(st.integers(0, height - 1)), draw(st.integers(0, width - 1))
    return png_bytes(marker_image(width, height, row, col))


# ---------------------------------------------------------------------------- OBJ, PLY, OFF


@st.composite
def obj_models(draw: st.DrawFn) -> Model:
    """OBJ with an MTL (Kd, d, map_Kd and a texture), vertex colours, or no colour."""
    kind = draw(st.sampled_from(["texture", "kd", "vertex", "none"]))
    text = obj_text(uv=kind == "texture", colours=kind == "vertex")
    files = {}
    if kind in ("vertex", "none"):
        text = text.replace("mtllib model.mtl\n", "").replace("usemtl painted\n", "")
    else:
        red, green, blue = (draw(st.floats(0, 1)) for _ in range(3))
        mtl = f"newmtl painted\nKd {red:.4f} {green:.4f} {blue:.4f}\n"
        if draw(st.booleans()):
            mtl += f"d {draw(st.floats(0, 1)):.3f}\n"
        if kind == "texture":
            mtl += "map_Kd tex.png\n"
            files["tex.png"] = draw(textures())
        files["model.mtl"] = mtl.encode()
    return Model("m.obj", {"m.obj": text.encode(), **files})


def _ply_binary(order: str, uv: bool, vertex_colour: bool, face_colour: bool) -> bytes:
    """The tetrahedron (12 unshared corners) as binary PLY with the chosen properties."""
    mark = "<" if order == "little" else ">"
    header = [
        "ply",
        f"format binary_{order}_endian 1.0",
        "element vertex 12",
        *(f"property float {axis}" for axis in ("x", "y", "z", *(("s", "t") if uv else ()))),
        *(f"property uchar {c}" for c in ("red", "green", "blue", "alpha") if vertex_colour),
        "element face 4",
        "property list uchar int vertex_indices",
        *(f"property uchar {c}" for c in ("red", "green", "blue") if face_colour),
        "end_header",
    ]
    body = b""
    uvs = CORNER_UV.reshape(-1, 2)
    for i, corner in enumerate(CORNERS):
        body += struct.pack(mark + "3f", *corner)
        body += struct.pack(mark + "2f", *uvs[i]) if uv else b""
        body += bytes([40 + 10 * i, 200, 30, 255]) if vertex_colour else b""
    for f in range(4):
        body += struct.pack(mark + "B3i", 3, 3 * f, 3 * f + 1, 3 * f + 2)
        body += bytes([60 * f, 100, 250]) if face_colour else b""
    return ("\n".join(header) + "\n").encode() + body


@st.composite
def ply_models(draw: st.DrawFn) -> Model:
    """PLY, ASCII or binary, with a texture and u v, vertex or face colours, or none."""
    encoding = draw(st.sampled_from(["ascii", "little", "big"]))
    kind = draw(st.sampled_from(["texture", "vertex", "face", "none"]))
    files = {"tex.png": draw(textures())} if kind == "texture" else {}
    if encoding == "ascii" and kind != "face":
        texture = "tex.png" if kind == "texture" else None
        extra = "red green blue" if kind == "vertex" else ""
        data = ply_text(texture_file=texture, uv=kind == "texture", extra=extra).encode()
    else:
        data = _ply_binary(
            "little" if encoding == "ascii" else encoding,
            kind == "texture",
            kind == "vertex",
            kind == "face",
        )
        if kind == "texture":
            data = data.replace(b"element vertex", b"comment TextureFile tex.png\nelement vertex")
    return Model("m.ply", {"m.ply": data, **files})


@st.composite
def off_models(draw: st.DrawFn) -> Model:
    """OFF, optionally with per-face RGB colours."""
    coloured = draw(st.booleans())
    lines = ["OFF", f"{len(TET_VERTICES)} {len(TET_FACES)} 0"]
    lines += [" ".join(f"{c:g}" for c in v) for v in TET_VERTICES]
    for i, face in enumerate(TET_FACES):
        lines.append("3 " + " ".join(map(str, face)) + (f" {50 * i} 120 200" if coloured else ""))
    return Model("m.off", {"m.off": ("\n".join(lines) + "\n").encode()})


@st.composite
def stl_models(draw: st.DrawFn) -> Model:
    """STL, ASCII or binary (with random attribute bytes)."""
    triangles = TET_VERTICES[TET_FACES]
    if draw(st.booleans()):
        lines = ["solid fuzz"]
        for tri in triangles:
            lines += ["facet normal 0 0 0", "outer loop"]
            lines += [f"vertex {x:g} {y:g} {z:g}" for x, y, z in tri]
            lines += ["endloop", "endfacet"]
        return Model("m.stl", {"m.stl": ("\n".join([*lines, "endsolid fuzz"]) + "\n").encode()})
    attribute = draw(st.integers(0, 0xFFFF))
    data = b"fuzz binary STL".ljust(80, b"\0") + struct.pack("<I", len(triangles))
    for tri in triangles:
        data += struct.pack("<12fH", 0, 0, 0, *tri.reshape(-1), attribute)
    return Model("m.stl", {"m.stl": data})


# ---------------------------------------------------------------------------- glTF, GLB


@st.composite
def gltf_models(draw: st.DrawFn) -> Model:
    """glTF (JSON + .bin) or GLB with a texture (file or buffer), COLOR_0, a factor, or none."""
    kind = draw(st.sampled_from(["texture", "vertex", "factor", "none"]))
    glb = draw(st.booleans())
    factor = [draw(st.floats(0, 1)) for _ in range(3)] + [1.0]
    if kind == "vertex":
        colours = np.tile([0.2, 0.5, 0.9, 1.0], (12, 1)) * np.linspace(0.5, 1, 12)[:, None]
        document, binary = gltf_parts(colour_linear=colours)
    else:
        document, binary = gltf_parts(factor=factor if kind != "none" else None)
    files = {}
    if kind == "texture":
        image = draw(textures())
        document["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        document["textures"] = [{"source": 0}]
        if draw(st.booleans()):
            document["samplers"] = [{"wrapS": 33071, "wrapT": 10497, "magFilter": 9728}]
            document["textures"][0]["sampler"] = 0
        if glb and draw(st.booleans()):
            document, binary = embed_image(image)(document, binary)
        else:
            document["images"] = [{"uri": "tex.png"}]
            files["tex.png"] = image
    if kind == "none":
        del document["materials"]
        del document["meshes"][0]["primitives"][0]["material"]
    if draw(st.booleans()):  # a parent node with a transform
        document["nodes"].append({"children": [0], "translation": [1, 2, 3], "scale": [2, 2, 2]})
        document["scenes"] = [{"nodes": [1]}]
    if glb:
        return Model("m.glb", {"m.glb": glb_bytes(document, binary), **files})
    document["buffers"][0]["uri"] = "model.bin"
    text = json.dumps(document).encode()
    return Model("m.gltf", {"m.gltf": text, "model.bin": binary, **files})


# ---------------------------------------------------------------------------- 3MF


def _mesh_object(object_id: int, triangle_attributes: list[str], own: str = "") -> str:
    vertices = "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in TET_VERTICES)
    triangles = "".join(
        f'<triangle v1="{a}" v2="{b}" v3="{c}"{extra}/>'
        for (a, b, c), extra in zip(TET_FACES, triangle_attributes, strict=True)
    )
    return (
        f'<object id="{object_id}" type="model"{own}><mesh><vertices>{vertices}</vertices>'
        f"<triangles>{triangles}</triangles></mesh></object>"
    )


def _model_part(resources: str, build: str) -> bytes:
    return (
        f'<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xml:lang="en-US" '
        f'xmlns="{CORE_NS}" xmlns:m="{MATERIAL_NS}" xmlns:p="{PRODUCTION_NS}">'
        f"<resources>{resources}</resources><build>{build}</build></model>"
    ).encode()


#: A triangle's property attributes: mostly all three corners, sometimes p1 alone, rarely
#: no p1 (the object's pid and pindex then apply).
STYLES = ["corners"] * 10 + ["p1"] * 5 + ["pid only"]


@st.composite
def threemf_models(draw: st.DrawFn) -> Model:
    """3MF with colour groups, base materials, a texture2dgroup, multiproperties, components,
    build items with transforms, and optionally the mesh in a second part (``p:path``)."""
    n_colours = draw(st.integers(1, 4))
    colours = [f"#{draw(st.integers(0, 0xFFFFFF)):06X}" for _ in range(n_colours)]
    groups = {"2": n_colours, "3": 2}  # property group id -> its size
    resources = '<m:colorgroup id="2">' + "".join(f'<m:color color="{c}"/>' for c in colours)
    resources += '</m:colorgroup><basematerials id="3"><base name="a" displaycolor="#FF0000"/>'
    resources += '<base name="b" displaycolor="#00FF0080"/></basematerials>'
    entries = {"_rels/.rels": RELS.encode()}
    if draw(st.booleans()):
        entries["3D/Textures/tex.png"] = draw(textures())
        coords = "".join(f'<m:tex2coord u="{u}" v="{v}"/>' for u, v in CORNER_UV.reshape(-1, 2))
        resources += '<m:texture2d id="5" path="/3D/Textures/tex.png" contenttype="image/png"/>'
        resources += f'<m:texture2dgroup id="4" texid="5">{coords}</m:texture2dgroup>'
        groups["4"] = 12
    if draw(st.booleans()):
        pids = draw(
            st.sampled_from(
                [p for p in (["3", "2"], ["2", "4"], ["2", "2"]) if "4" in groups or "4" not in p]
            )
        )
        n_multi = draw(st.integers(1, 4))
        rows = [
            " ".join(str(draw(st.integers(0, groups[p] - 1))) for p in pids) for _ in range(n_multi)
        ]
        method = draw(st.sampled_from(["", ' blendmethods="mix"', ' blendmethods="multiply"']))
        resources += f'<m:multiproperties id="6" pids="{" ".join(pids)}"{method}>'
        resources += "".join(f'<m:multi pindices="{row}"/>' for row in rows)
        resources += "</m:multiproperties>"
        groups["6"] = n_multi
    # The object's pid and pindex apply to triangles without a pid, or with a pid but no p1
    # (as lib3mf reads them); a triangle's p2 and p3 default to its p1.
    own = draw(st.sampled_from(["", *groups]))
    pindex = f' pindex="{draw(st.integers(0, groups[own] - 1))}"' if own else ""
    attributes = []
    for _ in TET_FACES:
        pid = draw(st.sampled_from(["", *groups]))
        style = draw(st.sampled_from(STYLES)) if pid else ""
        corners = [draw(st.integers(0, groups[pid] - 1)) for _ in range(3)] if pid else []
        attributes.append(
            {
                "": "",
                "pid only": f' pid="{pid}"',
                "p1": f' pid="{pid}" p1="{corners[0] if corners else 0}"',
                "corners": f' pid="{pid}"'
                + "".join(f' p{k + 1}="{c}"' for k, c in enumerate(corners)),
            }[style]
        )
    mesh = _mesh_object(1, attributes, f' pid="{own}"{pindex}' if own else "")
    transform = ' transform="1 0 0 0 1 0 0 0 1 5 6 7"' if draw(st.booleans()) else ""
    layout = draw(st.sampled_from(["item", "component", "part"]))
    if layout == "item":
        resources, build = resources + mesh, f'<item objectid="1"{transform}/>'
    else:
        where = ' p:path="/3D/part.model"' if layout == "part" else ""
        wrapper = f'<object id="7" type="model"><components><component objectid="1"{where}'
        wrapper += f"{transform}/></components></object>"
        if layout == "part":
            entries["3D/part.model"] = _model_part(resources + mesh, "")
            resources += wrapper
        else:
            resources += mesh + wrapper
        build = '<item objectid="7"/>'
    entries[MODEL_ENTRY] = _model_part(resources, build)
    return Model("m.3mf", {}, entries)


# ---------------------------------------------------------------------------- VRML


@st.composite
def vrml_models(draw: st.DrawFn) -> Model:
    """VRML 2.0 IndexedFaceSet with a texture, per-vertex or per-face colours, or a Material."""
    kind = draw(st.sampled_from(["texture", "vertex", "face", "material", "none"]))
    points = ", ".join(" ".join(f"{c:g}" for c in p) for p in TET_VERTICES)
    index = " ".join(" ".join(map(str, f)) + " -1" for f in TET_FACES)
    extra, appearance, files = "", "", {}
    if kind in ("vertex", "face"):
        rows = ", ".join(f"{0.2 * i:g} 0.5 {1 - 0.2 * i:g}" for i in range(4))
        per_vertex = "TRUE" if kind == "vertex" else "FALSE"
        extra = f"colorPerVertex {per_vertex} color Color {{ color [ {rows} ] }}"
        if draw(st.booleans()):
            extra += " colorIndex [ " + ("0 1 2 3" if kind == "face" else index) + " ]"
    elif kind == "texture":
        uv = ", ".join(f"{u:g} {v:g}" for u, v in CORNER_UV.reshape(-1, 2))
        extra = f"texCoord TextureCoordinate {{ point [ {uv} ] }} texCoordIndex [ "
        extra += " ".join(f"{3 * i} {3 * i + 1} {3 * i + 2} -1" for i in range(4)) + " ]"
        appearance = 'texture ImageTexture { url "tex.png" }'
        files["tex.png"] = draw(textures())
    if kind in ("material", "texture"):
        red = draw(st.floats(0, 1))
        appearance += f" material Material {{ diffuseColor {red:.3f} 0.5 0.5 transparency 0.1 }}"
    shape = "Shape { "
    if appearance:
        shape += f"appearance Appearance {{ {appearance} }} "
    shape += (
        f"geometry DEF SET IndexedFaceSet {{ coord Coordinate {{ point [ {points} ] }} "
        f"coordIndex [ {index} ] {extra} }} }}"
    )
    for _ in range(draw(st.integers(0, 2))):
        shape = (
            f"Transform {{ translation 1 2 3 scale 2 2 2 rotation 0 0 1 0.5 children [ {shape} ] }}"
        )
    text = f"#VRML V2.0 utf8\n# fuzz model\n{shape}\n"
    return Model("m.wrl", {"m.wrl": text.encode(), **files})


MODELS = {
    "obj": obj_models(),
    "ply": ply_models(),
    "gltf": gltf_models(),
    "3mf": threemf_models(),
    "wrl": vrml_models(),
    "stl": stl_models(),
    "off": off_models(),
}
