"""Writers of small model files with known content, for loader tests (written by hand
from the format specifications, independent of the loaders under test)."""

from __future__ import annotations

import io
import json
import struct
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

# A closed tetrahedron (outward faces) with its faces unshared: 12 corners, so that
# every face can carry its own UVs and colours and the loader must merge the seams.
TET_VERTICES = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], dtype=np.float64)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
# Per-corner UVs of the tetrahedron's 12 unshared corners (v up, OBJ convention).
CORNER_UV = np.tile(np.array([[0.05, 0.05], [0.95, 0.05], [0.05, 0.95]]), (4, 1, 1))


def marker_image(width: int, height: int, row: int, col: int) -> np.ndarray:
    """A smooth grey ramp image with one red marker pixel at (row, col), RGBA uint8."""
    image = np.zeros((height, width, 4), dtype=np.uint8)
    image[..., :3] = 90
    image[..., 1] = np.linspace(0, 255, height, dtype=np.uint8)[:, None]
    image[..., 3] = 255
    image[row, col] = (255, 0, 0, 255)
    return image


def png_bytes(image: np.ndarray, mode: str = "RGBA") -> bytes:
    buffer = io.BytesIO()
    picture = Image.fromarray(image, "RGBA")
    if mode == "P":
        picture = picture.convert("RGB").quantize(colors=256)
    picture.save(buffer, format="PNG")
    return buffer.getvalue()


def write_obj(
    path: Path,
    corner_uv: np.ndarray,
    image: np.ndarray | None,
    map_kd: str = "tex.png",
    image_name: str | None = None,
    mtl_name: str = "model.mtl",
    write_mtl: bool = True,
) -> None:
    """Tetrahedron OBJ with per-corner UVs (OBJ convention: v up) and an MTL."""
    lines = [f"mtllib {mtl_name}"]
    lines += [f"v {x} {y} {z}" for x, y, z in TET_VERTICES]
    lines += [f"vt {u} {v}" for u, v in corner_uv.reshape(-1, 2)]
    lines.append("usemtl painted")
    for i, face in enumerate(TET_FACES):
        lines.append("f " + " ".join(f"{v + 1}/{3 * i + c + 1}" for c, v in enumerate(face)))
    path.write_text("\n".join(lines) + "\n")
    if write_mtl:
        (path.parent / mtl_name).write_text(f"newmtl painted\nKd 1 1 1\nmap_Kd {map_kd}\n")
    if image is not None:
        (path.parent / (image_name or map_kd)).write_bytes(png_bytes(image))


def write_glb(
    path: Path,
    corner_uv_gltf: np.ndarray | None,
    image: np.ndarray | None,
    palette: bool = False,
    factor: list[float] | None = None,
    corner_colour_linear: np.ndarray | None = None,
) -> None:
    """Tetrahedron GLB (12 unshared vertices) with a base-colour texture in its buffer.

    ``corner_uv_gltf`` is in glTF's convention: origin at the top-left of the image.
    Without UVs and image: ``corner_colour_linear`` as ``COLOR_0`` (linear RGBA floats).
    """
    if corner_uv_gltf is not None and image is not None:
        document, binary = gltf_parts(factor=factor, uv_gltf=corner_uv_gltf.reshape(-1, 2))
        data = png_bytes(image, "P" if palette else "RGBA")
        document, binary = embed_image(data)(document, binary)
        document["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        document["textures"] = [{"source": 0}]
    else:
        assert corner_colour_linear is not None
        document, binary = gltf_parts(colour_linear=corner_colour_linear.reshape(-1, 4))
    path.write_bytes(glb_bytes(document, binary))


def gltf_parts(
    *,
    image: dict | None = None,
    factor: list | None = None,
    tex_coord: int = 0,
    texture_extensions: dict | None = None,
    uv_gltf: np.ndarray | None = None,
    colour_linear: np.ndarray | None = None,
) -> tuple[dict, bytes]:
    """glTF document and binary buffer of the tetrahedron (12 corners), UVs, one material.

    ``image`` is the glTF image object (``{"uri": ...}``), or None for no texture;
    ``uv_gltf`` the corners' UVs in glTF's convention (origin at the top-left; default
    :data:`CORNER_UV` flipped); ``colour_linear`` ``(12, 4)`` gives ``COLOR_0`` instead of
    UVs and no material.
    """
    corners_mm = TET_VERTICES[TET_FACES].reshape(-1, 3)
    # glTF is in metres with +Y up: the tetrahedron (mm, +Z up) turned by the inverse of
    # Blender's import (x, y, z) -> (x, -z, y), so the loader gives TET_VERTICES back
    x, y, z = corners_mm.T
    positions = (np.column_stack([x, z, -y]) / 1000.0).astype(np.float32)
    if uv_gltf is None:
        uv_gltf = CORNER_UV.reshape(-1, 2).copy()
        uv_gltf[:, 1] = 1.0 - uv_gltf[:, 1]  # glTF: v grows down from the top-left
    second = np.asarray(uv_gltf if colour_linear is None else colour_linear, np.float32)
    indices = np.arange(12, dtype=np.uint32)
    blobs = [positions.tobytes(), second.reshape(12, -1).tobytes(), indices.tobytes()]
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
    if colour_linear is not None:
        document["accessors"][1]["type"] = "VEC4"
        del document["materials"]
        document["meshes"] = [
            {"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2}]}
        ]
    if image is not None:
        info: dict = {"index": 0, "texCoord": tex_coord}
        if texture_extensions:
            info["extensions"] = texture_extensions
        pbr["baseColorTexture"] = info
        document["images"] = [image]
        document["textures"] = [{"source": 0}]
    return document, binary


def glb_bytes(document: dict, binary: bytes) -> bytes:
    return glb_chunks(json.dumps(document).encode(), binary)


def glb_chunks(text: bytes, binary: bytes) -> bytes:
    """A GLB of a JSON chunk ``text`` (any bytes, padded with spaces) and a BIN chunk."""
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text
    body += struct.pack("<I4s", len(binary), b"BIN\0") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


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


CORE_NS = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
MATERIAL_NS = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"


def write_3mf(
    path: Path,
    *,
    unit: str = "millimeter",
    colours: list[str] | None = None,
    corner_colour_index: np.ndarray | None = None,
    texture: np.ndarray | None = None,
    corner_uv: np.ndarray | None = None,
    extra_entries: dict[str, bytes] | None = None,
) -> None:
    """Tetrahedron 3MF with a colour group (per-corner indices) or a texture group."""
    resources = []
    triangles = []
    if colours is not None:
        body = "".join(f'<m:color color="{c}"/>' for c in colours)
        resources.append(f'<m:colorgroup id="2">{body}</m:colorgroup>')
    if texture is not None:
        assert corner_uv is not None
        resources.append(
            '<m:texture2d id="3" path="/3D/Textures/tex.png" contenttype="image/png"/>'
        )
        coords = "".join(f'<m:tex2coord u="{u}" v="{v}"/>' for u, v in corner_uv.reshape(-1, 2))
        resources.append(f'<m:texture2dgroup id="4" texid="3">{coords}</m:texture2dgroup>')
    for i, (a, b, c) in enumerate(TET_FACES):
        attrs = ""
        if corner_colour_index is not None:
            p = corner_colour_index[i]
            attrs = f' pid="2" p1="{p[0]}" p2="{p[1]}" p3="{p[2]}"'
        elif texture is not None:
            attrs = f' pid="4" p1="{3 * i}" p2="{3 * i + 1}" p3="{3 * i + 2}"'
        triangles.append(f'<triangle v1="{a}" v2="{b}" v3="{c}"{attrs}/>')
    vertices = "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in TET_VERTICES)
    model = (
        f'<?xml version="1.0" encoding="UTF-8"?><model unit="{unit}" xml:lang="en-US" '
        f'xmlns="{CORE_NS}" xmlns:m="{MATERIAL_NS}"><resources>{"".join(resources)}'
        f'<object id="1" type="model"><mesh><vertices>{vertices}</vertices>'
        f"<triangles>{''.join(triangles)}</triangles></mesh></object></resources>"
        '<build><item objectid="1"/></build></model>'
    )
    rels = (
        '<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.'
        'openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel'
        '.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/'
        '3dmodel"/></Relationships>'
    )
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("_rels/.rels", rels)
        archive.writestr("3D/3dmodel.model", model)
        if texture is not None:
            archive.writestr("3D/Textures/tex.png", png_bytes(texture))
        for name, data in (extra_entries or {}).items():
            archive.writestr(name, data)


def locate(mesh, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Face index and barycentric coordinates of a point lying on a loaded mesh's surface."""
    import trimesh

    triangles = mesh.vertices[mesh.faces]
    bary = trimesh.triangles.points_to_barycentric(
        triangles, np.repeat(point[None], len(triangles), 0)
    )
    back = np.einsum("fc,fck->fk", bary, triangles)
    tolerance = 1e-6 * max(1.0, float(np.abs(mesh.vertices).max()))
    inside = (bary >= -1e-9).all(axis=1) & (np.linalg.norm(back - point, axis=1) < tolerance)
    face = int(np.flatnonzero(inside)[0])
    return np.array([face]), bary[face][None]


def j750_layer_model(rule=None):
    """The optical rule's model of the J750 (its optics, separation and backing)."""
    from shellvox.config import MaterialSettings
    from shellvox.printer import build_material_plan, layer_model, load_profile
    from shellvox.thickness import DEFAULT_RULE

    layers = (rule or DEFAULT_RULE).layers
    profile = load_profile("j750")
    plan = build_material_plan(
        profile, MaterialSettings(), colour_layers=layers.colour, n_bands=layers.n_layers
    )
    return layer_model(profile, plan, layers.backing_mm)
