"""glTF 2.0 / GLB: the document is checked and the colour read here, the geometry by trimesh.

trimesh reads geometry, node transforms, ``TEXCOORD_0`` and ``COLOR_0`` well, but it
drops an image it cannot read or that lies outside the folder without a word, decodes
textures of any size, ignores buffer ``byteLength`` and rounds ``baseColorFactor`` to
8 bits. So before trimesh sees the file:

- the buffers are checked against the bytes that really exist (a GLB that declares a
  1e12-byte buffer is refused), buffer views and accessors against their buffers, and a
  buffer-less accessor may not hold more than ``3 * max_faces`` items;
- external URIs follow the path policy of :mod:`pipeline.loading.references` (inside the
  model's folder unless ``--force``; ``data:`` URIs are fine; remote URIs are refused);
- the base colour of every material is read from the document: ``baseColorFactor``
  (linear light, kept as float), ``baseColorTexture`` decoded by
  :func:`pipeline.loading.images.read_textures` (pixel budget, missing or unreadable ->
  error, or ``--colour`` with a warning), its sampler's wrap and filter.
  ``KHR_materials_pbrSpecularGlossiness`` (``diffuseFactor``, ``diffuseTexture``) is read
  the same way;
- trimesh is then given a copy of the document in which every primitive has a material
  of its own, named after the primitive, and no images, so each loaded part is matched
  to its primitive exactly and no image is read twice.

A primitive's colour, per the glTF specification: texture x factor (with the
material's ``TEXCOORD_n`` moved by its ``KHR_texture_transform``,
:mod:`pipeline.loading.gltf_texcoord`), else ``COLOR_0`` x factor as vertex colours
(``COLOR_0`` is linear light), else the factor. A declared colour that cannot be used
(a texture on a primitive without its ``TEXCOORD_n``, ``COLOR_0`` beside a texture) is
reported in a one-line warning naming what is used.
"""

from __future__ import annotations

import base64
import binascii
import io
import json
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np
import trimesh
from numpy.typing import NDArray

from pipeline.config import LoadOptions
from pipeline.errors import InputError, ShellvoxWarning
from pipeline.loading.combine import combine_parts
from pipeline.loading.gltf_texcoord import primitive_uv, texture_transform
from pipeline.loading.images import TextureRef, read_textures
from pipeline.loading.references import check_inside
from pipeline.mesh import ColouredMesh
from pipeline.texture import FilterMode, Material, WrapMode
from voxel.srgb import encode_uint8

GL_WRAP: dict[int, WrapMode] = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
GL_NEAREST = (9728, 9984, 9986)
COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
NORMALISED_MAX = {5121: 255.0, 5123: 65535.0}
TAG = "shellvox-primitive"
FIX = "the file is truncated or corrupt; export it again"


@dataclass(frozen=True)
class _Document:
    """A parsed glTF or GLB file."""

    path: Path
    json: dict[str, Any]
    glb: bool
    data: bytes  # the whole file
    json_chunk: tuple[int, int]  # GLB: start and end of the JSON chunk (header included)
    binary: bytes | None  # GLB: the BIN chunk


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
    """Read a glTF 2.0 or GLB file into an unmerged mesh in file units.

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


def _read_gltf(path: Path, options: LoadOptions) -> ColouredMesh:
    document = _read_document(path)
    buffers = _check_buffers(document, options)
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


def _read_document(path: Path) -> _Document:
    data = path.read_bytes()
    if data[:4] != b"glTF":
        try:
            document = json.loads(data)
        except (ValueError, UnicodeDecodeError) as error:
            raise InputError(path, f"is neither GLB nor glTF JSON ({error})", FIX) from None
        return _checked(_Document(path, document, False, data, (0, 0), None))
    try:
        _, version, length = struct.unpack_from("<4sII", data, 0)
        json_length, json_type = struct.unpack_from("<I4s", data, 12)
    except struct.error:
        raise InputError(path, "has a truncated GLB header", FIX) from None
    if length > len(data) or json_type != b"JSON" or 20 + json_length > len(data):
        raise InputError(
            path,
            f"is a truncated or malformed GLB (it declares {length:,} bytes, holds {len(data):,})",
            FIX,
        )
    end = 20 + json_length
    binary = None
    if end + 8 <= len(data):
        bin_length, bin_type = struct.unpack_from("<I4s", data, end)
        if bin_type == b"BIN\0":
            if end + 8 + bin_length > len(data):
                raise InputError(
                    path,
                    f"its BIN chunk declares {bin_length:,} bytes but the file ends "
                    f"{len(data) - end - 8:,} bytes after its start",
                    FIX,
                )
            binary = data[end + 8 : end + 8 + bin_length]
    try:
        document = json.loads(data[20:end])
    except (ValueError, UnicodeDecodeError) as error:
        raise InputError(path, f"has a malformed JSON chunk ({error})", FIX) from None
    if version != 2:
        raise InputError(path, f"is GLB version {version}", "export it as glTF 2.0")
    return _checked(_Document(path, document, True, data, (12, end), binary))


def _checked(document: _Document) -> _Document:
    if not isinstance(document.json, dict):
        raise InputError(document.path, "its JSON is not a glTF document", FIX)
    version = str(document.json.get("asset", {}).get("version", "2.0"))
    if not version.startswith("2"):
        raise InputError(document.path, f"is glTF version {version}", "export it as glTF 2.0")
    return document


def _check_buffers(document: _Document, options: LoadOptions) -> list[Path | bytes | None]:
    """Check buffers, views and accessors; return where each buffer's bytes are."""
    path, tree = document.path, document.json
    sources: list[Path | bytes | None] = []
    lengths: list[int] = []
    for index, buffer in enumerate(tree.get("buffers", [])):
        declared = _count(path, f"buffer {index}", buffer.get("byteLength"))
        uri = buffer.get("uri")
        if uri is None:
            if not document.glb or index != 0:
                raise InputError(path, f"buffer {index} has no uri", FIX)
            source: Path | bytes | None = document.binary
            held, where = len(document.binary or b""), "the GLB's BIN chunk"
        elif str(uri).startswith("data:"):
            source = _data_uri(path, f"buffer {index}", str(uri))
            held, where = len(source), "its data: URI"
        else:
            file = _external(document, str(uri), f"buffer {index} ({uri!r})", options)
            if not file.is_file():
                raise InputError(
                    path,
                    f"buffer file {uri!r} is missing",
                    "put it beside the .gltf file, or export the model as one .glb",
                )
            source, held, where = file, file.stat().st_size, f"{uri!r}"
        if declared > held:
            raise InputError(
                path,
                f"buffer {index} declares {declared:,} bytes but {where} holds only {held:,}",
                FIX,
            )
        sources.append(source)
        lengths.append(declared)
    views = tree.get("bufferViews", [])
    for index, view in enumerate(views):
        buffer = view.get("buffer")
        offset = _count(path, f"bufferView {index} byteOffset", view.get("byteOffset", 0))
        length = _count(path, f"bufferView {index} byteLength", view.get("byteLength"))
        if not isinstance(buffer, int) or not 0 <= buffer < len(lengths):
            raise InputError(path, f"bufferView {index} refers to a missing buffer", FIX)
        if offset + length > lengths[buffer]:
            raise InputError(
                path,
                f"bufferView {index} ends at byte {offset + length:,}, past the end of "
                f"buffer {buffer} ({lengths[buffer]:,} bytes)",
                FIX,
            )
    for index, accessor in enumerate(tree.get("accessors", [])):
        _check_accessor(path, index, accessor, views, options)
    return sources


def _check_accessor(
    path: Path, index: int, accessor: dict[str, Any], views: list[Any], options: LoadOptions
) -> None:
    count = _count(path, f"accessor {index} count", accessor.get("count"))
    size = COMPONENT_BYTES.get(accessor.get("componentType", 0))
    components = TYPE_COMPONENTS.get(accessor.get("type", ""))
    if size is None or components is None:
        raise InputError(path, f"accessor {index} has an unknown componentType or type", FIX)
    view_index = accessor.get("bufferView")
    if view_index is None:  # zeros (or sparse): nothing bounds it but the face limit
        if count > 3 * options.max_faces and not options.force:
            raise InputError(
                path,
                f"accessor {index} declares {count:,} items without data, more than "
                f"3 x --max-faces ({3 * options.max_faces:,})",
                "export it again, or pass --force",
            )
        return
    if not isinstance(view_index, int) or not 0 <= view_index < len(views):
        raise InputError(path, f"accessor {index} refers to a missing bufferView", FIX)
    view = views[view_index]
    offset = _count(path, f"accessor {index} byteOffset", accessor.get("byteOffset", 0))
    element = size * components
    stride = _count(path, f"bufferView {view_index} byteStride", view.get("byteStride", element))
    needed = offset + (max(count, 1) - 1) * max(stride, element) + element if count else 0
    if needed > view["byteLength"]:
        raise InputError(
            path,
            f"accessor {index} needs {needed:,} bytes but bufferView {view_index} holds "
            f"{view['byteLength']:,}",
            FIX,
        )


def _count(path: Path, what: str, value: Any) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise InputError(path, f"{what} is {value!r}, not a count of bytes or items", FIX)
    return value


def _data_uri(path: Path, what: str, uri: str) -> bytes:
    head, _, payload = uri.partition(",")
    try:
        if head.endswith(";base64"):
            return base64.b64decode(payload, validate=True)
        return unquote(payload).encode("latin-1")
    except (binascii.Error, ValueError, UnicodeEncodeError):
        raise InputError(path, f"{what} has a malformed data: URI", FIX) from None


def _external(document: _Document, uri: str, what: str, options: LoadOptions) -> Path:
    """Return the file an external URI names, under the path policy (remote URIs refused)."""
    if "://" in uri:
        raise InputError(
            document.path,
            f"{what} is a remote URI, which shellvox does not fetch",
            "download it into the model's folder and refer to it by a relative name",
        )
    candidate = document.path.parent / unquote(uri)
    return check_inside(document.path, candidate, what, force=options.force)


def _base_colours(document: _Document) -> list[_BaseColour]:
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
    document: _Document,
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
            source = _data_uri(path, label, str(image["uri"]))
        elif "uri" in image:
            label = f"image {image['uri']!r}"
            source = _external(document, str(image["uri"]), label, options)
        else:
            raise InputError(path, f"{label} has neither a uri nor a bufferView", FIX)
        refs.append(TextureRef(path, label, source, "put the image where the file says"))
    images = read_textures(refs, colour=options.colour, force=options.force)
    return dict(zip(used, images, strict=True))


def _tagged_primitives(document: _Document) -> list[tuple[int, int]]:
    return [
        (m, p)
        for m, mesh in enumerate(document.json.get("meshes", []))
        for p, _ in enumerate(mesh.get("primitives", []))
    ]


def _load_geometry(
    document: _Document, primitives: list[tuple[int, int]], options: LoadOptions
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
    document: _Document,
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
    faces = np.asarray(geometry.faces, dtype=np.int64)
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
                warnings.warn(
                    f"{path}: material {colour.name!r}: COLOR_0 vertex colours beside its "
                    "texture are ignored (texture x factor is used)",
                    ShellvoxWarning,
                    stacklevel=4,
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
        warnings.warn(
            f"{path}: the texture of material {colour.name!r} {problem}, which shellvox "
            "does not read; its baseColorFactor is used instead",
            ShellvoxWarning,
            stacklevel=4,
        )
    linear = colour.factor if vertex_colour is None else vertex_colour * colour.factor
    part["rgba"] = np.broadcast_to(encode_uint8(linear), (len(geometry.vertices), 4))[faces]
    return part


def _colour_0(
    document: _Document, geometry: trimesh.Trimesh, primitive: dict[str, Any]
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
