"""glTF 2.0 / GLB: the document is checked and the colour read here, the geometry by trimesh.

trimesh reads geometry, node transforms, ``TEXCOORD_0`` and ``COLOR_0`` well, but it
drops an image it cannot read or that lies outside the folder without a word, decodes
textures of any size, ignores buffer ``byteLength`` and rounds ``baseColorFactor`` to
8 bits. So before trimesh sees the file:

- the buffers, buffer views, accessors and external URIs are checked
  (:mod:`shellvox.loading.gltf._document`);
- the base colour of every material is read from the document: ``baseColorFactor``
  (linear light, kept as float), ``baseColorTexture`` decoded by
  :func:`shellvox.loading._images.read_textures` (pixel budget, missing or unreadable ->
  error, or ``--colour`` with a warning), its sampler's wrap and filter.
  ``KHR_materials_pbrSpecularGlossiness`` (``diffuseFactor``, ``diffuseTexture``) is read
  the same way;
- trimesh is then given a copy of the document in which every primitive has a material
  of its own, named after the primitive, and no images, so each loaded part is matched
  to its primitive exactly and no image is read twice.

A primitive's colour, per the glTF specification: texture x factor (with the
material's ``TEXCOORD_n`` moved by its ``KHR_texture_transform``,
:mod:`shellvox.loading.gltf._texcoord`), else ``COLOR_0`` x factor as vertex colours
(``COLOR_0`` is linear light), else the factor. A declared colour that cannot be used
(a texture on a primitive without its ``TEXCOORD_n``, ``COLOR_0`` beside a texture) is
reported in a one-line warning naming what is used.
"""

from __future__ import annotations

import io
import json
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, warn
from shellvox.loading._combine import checked_faces, combine_parts
from shellvox.loading._images import TextureRef, read_textures
from shellvox.loading.gltf._document import (
    FIX,
    GltfDocument,
    check_buffers,
    data_uri,
    external_file,
    read_document,
)
from shellvox.loading.gltf._texcoord import primitive_uv, texture_transform
from shellvox.model import ColouredMesh, FilterMode, Material, WrapMode
from shellvox.voxel.colour import encode_uint8

GL_WRAP: dict[int, WrapMode] = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
GL_NEAREST = (9728, 9984, 9986)
NORMALISED_MAX = {5121: 255.0, 5123: 65535.0}
TAG = "shellvox-primitive"


@dataclass(frozen=True)
class _BaseColour:
    """A material's base colour: factor, texture and how to sample it."""

    name: str
    factor: NDArray[np.float64]  # (4,) linear RGB + alpha
    image: int | None  # glTF image index
    tex_coord: int
    wrap: tuple[WrapMode, WrapMode]
    filter: FilterMode
    transform: NDArray[np.float64]  # (3, 3) KHR_texture_transform, glTF texture space


def read_gltf(path: Path, options: LoadOptions) -> ColouredMesh:
    """Read a glTF 2.0 or GLB file into an unmerged mesh in file units (metres, +Y up).

    :func:`shellvox.load_model` turns it +Z up and converts it to millimetres.

    Parameters
    ----------
    path : Path
        The ``.gltf`` or ``.glb`` file (the container is recognised by its content).
    options : LoadOptions
        ``colour`` replaces a missing or unreadable texture (with a warning); ``force``
        lifts the limits and reads files outside the model's folder (with a warning);
        ``max_faces`` bounds buffer-less accessors.

    Returns
    -------
    ColouredMesh
        Scene transforms applied, one colour source (see the module docstring).

    Raises
    ------
    InputError
        The document, a buffer or a texture is malformed, missing, too large or outside
        the model's folder.
    """
    try:
        return _read_gltf(path, options)
    except InputError:
        raise
    except (KeyError, IndexError, TypeError, AttributeError, ValueError) as error:
        # A safety net for a document whose structure is not glTF's (a string where an
        # object belongs...): the checks in this module name each known problem.
        raise InputError(
            path, f"has a malformed glTF document ({type(error).__name__}: {error})", FIX
        ) from None
    except RecursionError:  # JSON nested past Python's recursion limit
        raise InputError(path, "nests its JSON too deeply to read", FIX) from None


def _read_gltf(path: Path, options: LoadOptions) -> ColouredMesh:
    document = read_document(path)
    buffers = check_buffers(document, options)
    colours = _base_colours(document)
    images = _read_images(document, colours, buffers, options)
    primitives = _tagged_primitives(document)
    loaded = _load_geometry(document, primitives, options)
    parts = []
    for geometry, matrix in loaded:
        name = str(getattr(getattr(geometry.visual, "material", None), "name", "") or "")
        if not name.startswith(TAG):
            raise InputError(path, "has a primitive shellvox cannot match", "export it again")
        mesh_index, primitive_index = (int(i) for i in name.split(":")[1:])
        parts.append(
            _part(
                document,
                geometry,
                matrix,
                document.json["meshes"][mesh_index]["primitives"][primitive_index],
                colours,
                images,
                (buffers, options),
            )
        )
    if not parts:
        raise InputError(path, "contains no triangles", "export the mesh with its faces")
    return combine_parts(path, parts)


def _base_colours(document: GltfDocument) -> list[_BaseColour]:
    """Return the base colour of every material of the document, in material order."""
    path, tree = document.path, document.json
    textures, samplers = tree.get("textures", []), tree.get("samplers", [])
    result = []
    for index, material in enumerate(tree.get("materials", [])):
        name = str(material.get("name") or f"material {index}")
        pbr = material.get("pbrMetallicRoughness", {})
        gloss = material.get("extensions", {}).get("KHR_materials_pbrSpecularGlossiness")
        if gloss is not None and "pbrMetallicRoughness" not in material:
            factor_value, info = gloss.get("diffuseFactor"), gloss.get("diffuseTexture")
        else:
            factor_value, info = pbr.get("baseColorFactor"), pbr.get("baseColorTexture")
        factor = _factor(path, name, factor_value)
        image: int | None = None
        wrap: tuple[WrapMode, WrapMode] = ("repeat", "repeat")
        filt: FilterMode = "linear"
        tex_coord, transform = 0, np.eye(3)
        if info is not None:
            texture_index = info.get("index")
            if not isinstance(texture_index, int) or not 0 <= texture_index < len(textures):
                raise InputError(path, f"material {name!r} refers to a missing texture", FIX)
            texture = textures[texture_index]
            image = texture.get("source")
            if image is None:  # EXT_texture_webp, KHR_texture_basisu, ...
                image = next(
                    (e.get("source") for e in texture.get("extensions", {}).values()), None
                )
            if not isinstance(image, int) or not 0 <= image < len(tree.get("images", [])):
                raise InputError(path, f"texture {texture_index} refers to a missing image", FIX)
            sampler_index = texture.get("sampler")
            sampler = samplers[sampler_index] if isinstance(sampler_index, int) else {}
            wrap = (
                GL_WRAP.get(sampler.get("wrapS", 10497), "repeat"),
                GL_WRAP.get(sampler.get("wrapT", 10497), "repeat"),
            )
            filt = "nearest" if sampler.get("magFilter") in GL_NEAREST else "linear"
            transform, tex_coord = texture_transform(path, name, info)
        result.append(_BaseColour(name, factor, image, tex_coord, wrap, filt, transform))
    return result


def _factor(path: Path, name: str, value: Any) -> NDArray[np.float64]:
    """``baseColorFactor``: 4 linear values in [0, 1] (default white)."""
    if value is None:
        return np.ones(4)
    try:
        factor = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        factor = np.array([np.nan])
    if factor.shape == (3,):  # KHR diffuseFactor is RGBA too, but be lenient
        factor = np.append(factor, 1.0)
    if factor.shape != (4,) or not np.isfinite(factor).all():
        raise InputError(
            path,
            f"material {name!r} has a malformed baseColorFactor {value!r}",
            "it must be 4 numbers in [0, 1]; export it again",
        )
    return np.clip(factor, 0.0, 1.0)


def _read_images(
    document: GltfDocument,
    colours: list[_BaseColour],
    buffers: list[Path | bytes | None],
    options: LoadOptions,
) -> dict[int, NDArray[np.uint8] | None]:
    """Decode every image a material uses (None: replaced by ``--colour``)."""
    path, tree = document.path, document.json
    used = sorted({c.image for c in colours if c.image is not None})
    refs = []
    for index in used:
        image = tree["images"][index]
        label = f"image {index}" + (f" ({image['name']!r})" if image.get("name") else "")
        source: Path | bytes | None
        if "bufferView" in image:
            view = tree["bufferViews"][image["bufferView"]]
            data = buffers[view["buffer"]]
            start = view.get("byteOffset", 0)
            if isinstance(data, Path):
                with data.open("rb") as handle:
                    handle.seek(start)
                    source = handle.read(view["byteLength"])
            else:
                source = (data or b"")[start : start + view["byteLength"]]
        elif str(image.get("uri", "")).startswith("data:"):
            source = data_uri(path, label, str(image["uri"]))
        elif "uri" in image:
            label = f"image {image['uri']!r}"
            source = external_file(document, str(image["uri"]), label, options)
        else:
            raise InputError(path, f"{label} has neither a uri nor a bufferView", FIX)
        refs.append(TextureRef(path, label, source, "put the image where the file says"))
    images = read_textures(refs, colour=options.colour, force=options.force)
    return dict(zip(used, images, strict=True))


def _tagged_primitives(document: GltfDocument) -> list[tuple[int, int]]:
    return [
        (m, p)
        for m, mesh in enumerate(document.json.get("meshes", []))
        for p, _ in enumerate(mesh.get("primitives", []))
    ]


def _load_geometry(
    document: GltfDocument, primitives: list[tuple[int, int]], options: LoadOptions
) -> list[tuple[trimesh.Trimesh, NDArray[np.float64]]]:
    """Let trimesh read a copy of the document with one material per primitive.

    Returns every instance of a primitive in the scene with its ``(4, 4)`` node
    transform (``Scene.dump`` is not used: its copies drop ``COLOR_0``).
    """
    tree = json.loads(json.dumps(document.json))
    tree["materials"] = []
    for m, p in primitives:
        tree["meshes"][m]["primitives"][p]["material"] = len(tree["materials"])
        tree["materials"].append({"name": f"{TAG}:{m}:{p}"})
    for key in ("images", "textures", "samplers"):
        tree.pop(key, None)
    text = json.dumps(tree).encode()
    stream = io.BytesIO()
    if document.glb:
        text += b" " * (-len(text) % 4)
        rest = memoryview(document.data)[document.json_chunk[1] :]  # BIN and later chunks
        stream.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + len(rest)))
        stream.write(struct.pack("<I4s", len(text), b"JSON") + text)
        stream.write(rest)
    else:
        stream.write(text)
    stream.seek(0)
    resolver = trimesh.resolvers.FilePathResolver(str(document.path), allow_anywhere=options.force)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loaded = trimesh.load(
                stream,
                file_type="glb" if document.glb else "gltf",
                resolver=resolver,
                process=False,
                maintain_order=True,
            )
    except Exception as error:  # trimesh raises many types for malformed files
        raise InputError(
            document.path,
            f"could not be parsed as {'GLB' if document.glb else 'glTF'} "
            f"({type(error).__name__}: {error})",
            "check the file or export it again",
        ) from None
    if isinstance(loaded, trimesh.Trimesh):
        return [(loaded, np.eye(4))] if len(loaded.faces) else []
    instances: list[tuple[trimesh.Trimesh, NDArray[np.float64]]] = []
    if not isinstance(loaded, trimesh.Scene):
        return instances
    for node in loaded.graph.nodes_geometry:
        matrix, name = loaded.graph[node]
        geometry = loaded.geometry.get(name)
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
            instances.append((geometry, np.asarray(matrix, dtype=np.float64)))
    return instances


def _part(
    document: GltfDocument,
    geometry: trimesh.Trimesh,
    matrix: NDArray[np.float64],
    primitive: dict[str, Any],
    colours: list[_BaseColour],
    images: dict[int, NDArray[np.uint8] | None],
    context: tuple[list[Path | bytes | None], LoadOptions],
) -> dict[str, Any]:
    """Return one primitive instance's geometry and colour, as :func:`combine_parts` takes them.

    The node transform ``matrix (4, 4)`` is applied; a mirroring one reverses the
    corner order so faces stay outward (UVs and colours are gathered after).
    """
    path = document.path
    buffers, options = context
    faces = checked_faces(path, len(geometry.vertices), np.asarray(geometry.faces, np.int64))
    if np.linalg.det(matrix[:3, :3]) < 0:
        faces = faces[:, ::-1]
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused by load_model
        vertices = np.asarray(geometry.vertices, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    part: dict[str, Any] = {"vertices": vertices, "faces": faces}
    material_index = primitive.get("material")
    colour = colours[material_index] if isinstance(material_index, int) else None
    vertex_colour = _colour_0(document, geometry, primitive)
    if colour is None:  # the default material: white, so COLOR_0 alone
        if vertex_colour is not None:
            part["rgba"] = encode_uint8(vertex_colour)[faces]
        return part
    visual: Any = geometry.visual
    uv = visual.uv
    if colour.image is not None:
        image = images[colour.image]
        if image is None:  # replaced by --colour; read_textures warned
            assert options.colour is not None
            part["rgba"] = np.broadcast_to(np.asarray(options.colour, np.uint8), (*faces.shape, 4))
            return part
        uv, problem = primitive_uv(
            path,
            document.json,
            buffers,
            primitive,
            colour.tex_coord,
            colour.transform,
            None if uv is None else np.asarray(uv, np.float64),
            len(geometry.vertices),
        )
        if uv is not None:
            if vertex_colour is not None and not np.allclose(vertex_colour, 1.0):
                warn(
                    f"{path}: material {colour.name!r}: COLOR_0 vertex colours beside its "
                    "texture are ignored (texture x factor is used)",
                )
            part["uv"] = uv[faces]  # v up: the bottom-left origin used throughout shellvox
            part["material"] = Material(
                colour.name,
                factor=colour.factor,
                image=image,
                wrap=colour.wrap,
                filter=colour.filter,
            )
            return part
        warn(
            f"{path}: the texture of material {colour.name!r} {problem}, which shellvox "
            "does not read; its baseColorFactor is used instead",
        )
    linear = colour.factor if vertex_colour is None else vertex_colour * colour.factor
    part["rgba"] = np.broadcast_to(encode_uint8(linear), (len(geometry.vertices), 4))[faces]
    return part


def _colour_0(
    document: GltfDocument, geometry: trimesh.Trimesh, primitive: dict[str, Any]
) -> NDArray[np.float64] | None:
    """``COLOR_0`` as ``(V, 4) float64`` linear RGBA, or None."""
    accessor_index = primitive.get("attributes", {}).get("COLOR_0")
    visual: Any = geometry.visual
    raw = visual.vertex_attributes.get("color")
    if accessor_index is None or raw is None:
        return None
    accessor = document.json["accessors"][accessor_index]
    values = np.asarray(raw, dtype=np.float64).reshape(len(geometry.vertices), -1)
    values = values / NORMALISED_MAX.get(accessor.get("componentType"), 1.0)
    if values.shape[1] == 3:
        values = np.concatenate([values, np.ones((len(values), 1))], axis=1)
    if values.shape[1] != 4:
        raise InputError(document.path, "has a COLOR_0 that is neither VEC3 nor VEC4", FIX)
    return np.clip(values, 0.0, 1.0)
