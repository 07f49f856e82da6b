"""PLY, glTF/GLB, STL and OFF through trimesh, with colour taken over faithfully.

trimesh parses the geometry, the scene graph (glTF node transforms) and the visuals; this
module turns its visuals into shellvox's colour sources: textures with per-corner UVs and
per-primitive materials (glTF ``baseColorTexture`` x ``baseColorFactor``, with the file's
sampler wrap and filter), vertex colours (glTF ``COLOR_0`` is linear light and is encoded
to sRGB here), face colours, or none.
"""

from __future__ import annotations

import json
import struct
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from pipeline.errors import InputError, ShellvoxWarning
from pipeline.mesh import ColouredMesh
from pipeline.texture import Material, WrapMode, decode_uint8, encode_uint8, srgb_to_linear

GL_WRAP: dict[int, WrapMode] = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
GL_NEAREST = (9728, 9984, 9986)


def read_with_trimesh(path: Path, file_type: str) -> ColouredMesh:
    """Read a PLY, glTF/GLB, STL or OFF file into an unmerged mesh in file units."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loaded = trimesh.load(
                str(path), file_type=file_type, process=False, maintain_order=True
            )
    except Exception as error:  # trimesh raises many types for malformed files
        raise InputError(
            path,
            f"could not be parsed as {file_type.upper()} ({type(error).__name__}: {error})",
            "check the file or re-export it",
        ) from None
    if isinstance(loaded, trimesh.Scene):
        parts = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
    elif isinstance(loaded, trimesh.Trimesh):
        parts = [loaded]
    else:
        parts = []
    parts = [p for p in parts if len(p.faces)]
    if not parts:
        raise InputError(path, "contains no triangles", "export the mesh with its faces")
    samplers = _gltf_samplers(path) if file_type in ("glb", "gltf") else {}
    linear_vertex_colours = file_type in ("glb", "gltf")
    return _combine(path, [_part(p, samplers, linear_vertex_colours) for p in parts])


def _part(
    mesh: trimesh.Trimesh,
    samplers: dict[str, tuple[tuple[WrapMode, WrapMode], str]],
    linear_vertex_colours: bool,
) -> dict[str, Any]:
    faces = np.asarray(mesh.faces, dtype=np.int64)
    part: dict[str, Any] = {"vertices": np.asarray(mesh.vertices, np.float64), "faces": faces}
    visual: Any = mesh.visual
    kind = getattr(visual, "kind", None)
    if kind == "texture" and visual.uv is not None and len(visual.uv) == len(mesh.vertices):
        material = visual.material
        image = getattr(material, "baseColorTexture", None)
        if image is None:
            image = getattr(material, "image", None)
        factor = getattr(material, "baseColorFactor", None)
        factor_f = np.ones(4) if factor is None else np.asarray(factor, np.float64) / 255.0
        name = str(getattr(material, "name", "") or "")
        wrap, filt = samplers.get(name, (("repeat", "repeat"), "linear"))
        rgba = None if image is None else np.asarray(image.convert("RGBA"), dtype=np.uint8)
        part["material"] = Material(
            name,
            factor=factor_f,
            image=rgba,
            wrap=wrap,
            filter="nearest" if filt == "nearest" else "linear",
        )
        part["uv"] = np.asarray(visual.uv, np.float64)[faces]
        return part
    if kind == "texture":  # a material without texture coordinates: its factor colour
        factor = getattr(visual.material, "baseColorFactor", None)
        if factor is None:
            factor = getattr(visual.material, "main_color", None)
        if factor is not None:
            part["material"] = Material("colour", factor=_linear(np.asarray(factor), True))
            part["uv"] = np.zeros((len(faces), 3, 2))
        return part
    if kind == "vertex":
        colours = np.asarray(visual.vertex_colors, dtype=np.uint8)
        if linear_vertex_colours:
            colours = encode_uint8(colours / 255.0)
        part["rgba"] = colours[faces]
    elif kind == "face":
        part["rgba"] = np.repeat(np.asarray(visual.face_colors, np.uint8)[:, None], 3, axis=1)
    return part


def _linear(rgba_uint8: NDArray[np.generic], is_srgb: bool) -> NDArray[np.float64]:
    values = np.asarray(rgba_uint8, np.float64)[:4] / 255.0
    if is_srgb:
        values[:3] = srgb_to_linear(values[:3])
    return values


def _combine(path: Path, parts: list[dict[str, Any]]) -> ColouredMesh:
    """Join parts; the richest colour source wins (texture > vertex > face > none)."""
    offsets = np.cumsum([0] + [len(p["vertices"]) for p in parts[:-1]])
    vertices = np.concatenate([p["vertices"] for p in parts])
    faces = np.concatenate([p["faces"] + o for p, o in zip(parts, offsets, strict=True)])
    source = str(path)
    white = np.full((1, 3, 4), 255, np.uint8)
    if any("material" in p for p in parts):
        materials: list[Material] = []
        uv, index = [], []
        for p in parts:
            n = len(p["faces"])
            if "material" in p:
                uv.append(p["uv"])
                material = p["material"]
            else:
                if "rgba" in p:
                    warnings.warn(
                        f"{path}: a primitive's vertex or face colours are replaced "
                        "by its mean colour next to textured primitives",
                        ShellvoxWarning,
                        stacklevel=3,
                    )
                mean = decode_uint8(p["rgba"]).reshape(-1, 4).mean(0) if "rgba" in p else None
                material = Material("plain", factor=np.ones(4) if mean is None else mean)
                uv.append(np.zeros((n, 3, 2)))
            index.append(np.full(n, len(materials), np.int64))
            materials.append(material)
        return ColouredMesh(
            vertices,
            faces,
            "texture",
            corner_uv=np.concatenate(uv),
            face_material=np.concatenate(index),
            materials=tuple(materials),
            source=source,
        )
    if any("rgba" in p for p in parts):
        rgba = np.concatenate([p.get("rgba", np.repeat(white, len(p["faces"]), 0)) for p in parts])
        if (rgba == rgba[:, :1]).all():
            return ColouredMesh(vertices, faces, "face", face_rgba=rgba[:, 0].copy(), source=source)
        return ColouredMesh(vertices, faces, "vertex", corner_rgba=rgba, source=source)
    return ColouredMesh(vertices, faces, "none", source=source)


def _gltf_samplers(path: Path) -> dict[str, tuple[tuple[WrapMode, WrapMode], str]]:
    """Map glTF material names to (wrap, filter) of their base-colour texture's sampler."""
    try:
        data = path.read_bytes()
        if data[:4] == b"glTF":
            length, kind = struct.unpack_from("<I4s", data, 12)
            document = json.loads(data[20 : 20 + length]) if kind == b"JSON" else {}
        else:
            document = json.loads(data)
    except (ValueError, struct.error, OSError):
        return {}
    samplers = document.get("samplers", [])
    textures = document.get("textures", [])
    result: dict[str, tuple[tuple[WrapMode, WrapMode], str]] = {}
    for material in document.get("materials", []):
        info = material.get("pbrMetallicRoughness", {}).get("baseColorTexture")
        if info is None or info.get("index", -1) >= len(textures):
            continue
        sampler_index = textures[info["index"]].get("sampler")
        sampler = samplers[sampler_index] if sampler_index is not None else {}
        wrap = (
            GL_WRAP.get(sampler.get("wrapS", 10497), "repeat"),
            GL_WRAP.get(sampler.get("wrapT", 10497), "repeat"),
        )
        filt = "nearest" if sampler.get("magFilter") in GL_NEAREST else "linear"
        result[str(material.get("name", ""))] = (wrap, filt)
    return result
