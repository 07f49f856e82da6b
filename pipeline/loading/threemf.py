"""3MF reader (core + materials extension) from the package's XML.

trimesh reads 3MF geometry but drops colour groups and textures, so the XML is read here:
``<colorgroup>`` and ``<basematerials>`` colours per triangle or per vertex, ``<texture2d>``
with ``<texture2dgroup>`` coordinates, the model ``unit``, components and build-item
transforms. The archive is checked before anything is extracted: no entry may escape it,
and entries may not expand beyond sane sizes (zip-bomb guard). Textures are entries of
the package (never files outside it) and share the pixel budget of
:mod:`pipeline.loading.images`. Anything malformed (XML, zip CRC, colour strings,
transforms, numbers, references) is an :class:`~pipeline.errors.InputError`.

Reference: 3MF Core Specification 1.3 and Materials and Properties Extension 1.2.
"""

from __future__ import annotations

import warnings
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from pipeline.config import UNIT_MM, LoadOptions
from pipeline.errors import InputError, ShellvoxWarning
from pipeline.loading.images import TextureRef, read_textures
from pipeline.mesh import ColouredMesh
from pipeline.texture import FilterMode, Material, WrapMode, decode_uint8

CORE = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
MATERIAL = "{http://schemas.microsoft.com/3dmanufacturing/material/2015/02}"
MODEL_REL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"

MAX_ENTRY_BYTES = 4 * 1024**3
MAX_TOTAL_BYTES = 8 * 1024**3
MAX_RATIO = 200.0
UNITS_3MF = {
    "micron": "micron",
    "millimeter": "mm",
    "centimeter": "cm",
    "inch": "inch",
    "foot": "foot",
    "meter": "m",
}
WRAP_3MF: dict[str, WrapMode] = {
    "wrap": "repeat",
    "mirror": "mirror",
    "clamp": "clamp",
    "none": "clamp",
}


@dataclass
class _Properties:
    """Property groups of one model: colours (sRGBA) and texture coordinates by id."""

    colours: dict[str, NDArray[np.uint8]]
    uv: dict[str, tuple[NDArray[np.float64], int]]  # id -> (coordinates (n, 2), material)
    materials: list[Material]
    unsupported: dict[str, str]  # id -> element name of groups shellvox does not read
    fallback: NDArray[np.uint8]  # (4,) sRGBA for their triangles: --colour or white


def read_3mf(path: Path, options: LoadOptions) -> tuple[ColouredMesh, float]:
    """Read a 3MF file.

    Parameters
    ----------
    path : Path
        The ``.3mf`` package.
    options : LoadOptions
        ``colour`` replaces a missing or unreadable texture (with a warning); ``force``
        lifts the texture pixel budget.

    Returns
    -------
    mesh : ColouredMesh
        All build items, transformed, in the file's unit, not yet merged.
    mm_per_unit : float
        Millimetres per unit of the file (from the model's ``unit`` attribute).

    Raises
    ------
    InputError
        The package or its XML is malformed, or a texture cannot be used.
    """
    try:
        return _read_3mf(path, options)
    except InputError:
        raise
    except (ValueError, KeyError, IndexError, TypeError) as error:
        # A safety net: the checks below name each known problem.
        raise InputError(
            path, f"is malformed ({type(error).__name__}: {error})", "re-export it as 3MF"
        ) from None


def _read_3mf(path: Path, options: LoadOptions) -> tuple[ColouredMesh, float]:
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError):
        raise InputError(
            path, "is not a 3MF package (not a zip archive)", "re-export it as 3MF"
        ) from None
    with archive:
        _check_archive(path, archive)
        model_name = _model_part(path, archive)
        root = _parse_xml(path, archive, model_name)
        unit = root.get("unit", "millimeter")
        if unit not in UNITS_3MF:
            raise InputError(
                path, f"declares unknown unit {unit!r}", f"use one of {', '.join(UNITS_3MF)}"
            )
        resources = root.find(f"{CORE}resources")
        if resources is None:
            raise InputError(path, "has no <resources>", "re-export it as 3MF")
        properties = _read_properties(path, archive, resources, options)
        objects = {obj.get("id", ""): obj for obj in resources.iter(f"{CORE}object")}
        parts = []
        build = root.find(f"{CORE}build")
        items = [] if build is None else list(build.iter(f"{CORE}item"))
        for item in items:
            parts += _object_meshes(
                path,
                objects,
                item.get("objectid", ""),
                _transform(path, item.get("transform")),
                properties,
                0,
            )
    if not parts:
        raise InputError(path, "has no build items with meshes", "re-export it with geometry")
    return _combine(path, parts, properties.materials), UNIT_MM[UNITS_3MF[unit]]


def _check_archive(path: Path, archive: zipfile.ZipFile) -> None:
    total = 0
    for info in archive.infolist():
        name = PurePosixPath(info.filename.replace("\\", "/"))
        if name.is_absolute() or ".." in name.parts or ":" in info.filename:
            raise InputError(
                path,
                f"zip entry {info.filename!r} escapes the archive",
                "refusing to read it; re-export the 3MF from a trusted tool",
            )
        total += info.file_size
        ratio = info.file_size / max(info.compress_size, 1)
        if (
            info.file_size > MAX_ENTRY_BYTES
            or total > MAX_TOTAL_BYTES
            or (ratio > MAX_RATIO and info.file_size > 64 * 1024**2)
        ):
            raise InputError(
                path,
                f"zip entry {info.filename!r} expands to {info.file_size} "
                f"bytes (ratio {ratio:.0f}:1), a likely zip bomb",
                "refusing to read it; re-export the 3MF",
            )


def _model_part(path: Path, archive: zipfile.ZipFile) -> str:
    names = set(archive.namelist())
    if "_rels/.rels" in names:
        try:
            rels = ElementTree.fromstring(_read_entry(path, archive, "_rels/.rels"))
        except ElementTree.ParseError as error:
            raise InputError(
                path, f"its _rels/.rels is malformed XML ({error})", "re-export it as 3MF"
            ) from None
        for rel in rels:
            if rel.get("Type") == MODEL_REL and rel.get("Target"):
                target = str(rel.get("Target")).lstrip("/")
                if target in names:
                    return target
    for name in names:
        if name.lower().endswith(".model"):
            return name
    raise InputError(path, "has no 3D model part", "re-export it as 3MF")


def _read_entry(path: Path, archive: zipfile.ZipFile, name: str) -> bytes:
    try:
        with archive.open(name) as handle:
            data = handle.read(MAX_ENTRY_BYTES + 1)
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError) as error:
        # A bad CRC-32, corrupt deflate data or a truncated archive.
        raise InputError(
            path, f"zip entry {name!r} is corrupt ({error})", "re-export or re-download it"
        ) from None
    except (NotImplementedError, RuntimeError) as error:  # unknown compression, encrypted
        raise InputError(
            path, f"zip entry {name!r} cannot be read ({error})", "re-export it as 3MF"
        ) from None
    if len(data) > MAX_ENTRY_BYTES:
        raise InputError(path, f"zip entry {name!r} is larger than declared", "refusing it")
    return data


def _parse_xml(path: Path, archive: zipfile.ZipFile, name: str) -> ElementTree.Element:
    try:
        return ElementTree.fromstring(_read_entry(path, archive, name))
    except ElementTree.ParseError as error:
        raise InputError(path, f"model XML is malformed ({error})", "re-export it") from None


def _colour(path: Path, value: str | None) -> NDArray[np.uint8]:
    text = (value or "").strip()
    try:
        if len(text) not in (7, 9) or text[0] != "#":
            raise ValueError(text)
        rgba = bytes.fromhex(text[1:] + ("ff" if len(text) == 7 else ""))
    except ValueError:
        raise InputError(
            path, f"has a malformed colour {value!r}", "colours are #RRGGBB or #RRGGBBAA in hex"
        ) from None
    return np.frombuffer(rgba, dtype=np.uint8).copy()


def _numbers(path: Path, what: str, values: list[str], dtype: type) -> NDArray[np.generic]:
    """Parse XML attribute strings as numbers, or refuse naming what they are."""
    try:
        array: NDArray[np.generic] = np.array(values, dtype=np.str_).astype(dtype)
    except ValueError:
        bad = next((v for v in values if not _parses(v, dtype)), "?")
        raise InputError(path, f"has a non-numeric {what} {bad!r}", "re-export it as 3MF") from None
    return array


def _parses(value: str, dtype: type) -> bool:
    try:
        dtype(value)
    except ValueError:
        return False
    return True


def _read_properties(
    path: Path, archive: zipfile.ZipFile, resources: ElementTree.Element, options: LoadOptions
) -> _Properties:
    colours: dict[str, NDArray[np.uint8]] = {}
    for group in resources.iter(f"{MATERIAL}colorgroup"):
        colours[group.get("id", "")] = np.array(
            [_colour(path, c.get("color")) for c in group.iter(f"{MATERIAL}color")], np.uint8
        ).reshape(-1, 4)
    for group in resources.iter(f"{CORE}basematerials"):
        colours[group.get("id", "")] = np.array(
            [_colour(path, b.get("displaycolor")) for b in group.iter(f"{CORE}base")], np.uint8
        ).reshape(-1, 4)
    textures: dict[str, int] = {}
    elements = list(resources.iter(f"{MATERIAL}texture2d"))
    entries = set(archive.namelist())
    refs = []
    for texture in elements:
        name = (texture.get("path") or "").lstrip("/")
        data = _read_entry(path, archive, name) if name in entries else None
        refs.append(TextureRef(path, f"texture {name!r} (in the package)", data, "re-export it"))
    images = read_textures(refs, colour=options.colour, force=options.force)
    materials: list[Material] = []
    for texture, ref, image in zip(elements, refs, images, strict=True):
        wrap = (
            WRAP_3MF.get(texture.get("tilestyleu", "wrap"), "repeat"),
            WRAP_3MF.get(texture.get("tilestylev", "wrap"), "repeat"),
        )
        filt: FilterMode = "nearest" if texture.get("filter") == "nearest" else "linear"
        textures[texture.get("id", "")] = len(materials)
        if image is None:  # replaced by --colour (read_textures warned)
            assert options.colour is not None
            fallback = decode_uint8(np.asarray(options.colour, np.uint8))
            materials.append(Material(ref.label, factor=fallback))
        else:
            materials.append(Material(ref.label, image=image, wrap=wrap, filter=filt))
    uv: dict[str, tuple[NDArray[np.float64], int]] = {}
    for group in resources.iter(f"{MATERIAL}texture2dgroup"):
        texid = group.get("texid", "")
        if texid not in textures:
            raise InputError(
                path,
                f"texture group {group.get('id')!r} refers to unknown texture id {texid!r}",
                "re-export it as 3MF",
            )
        values = [c.get(k, "0") for c in group.iter(f"{MATERIAL}tex2coord") for k in "uv"]
        coords = _numbers(path, "texture coordinate", values, float).reshape(-1, 2)
        uv[group.get("id", "")] = (coords.astype(np.float64), textures[texid])
    unsupported = {
        element.get("id", ""): element.tag.rpartition("}")[2]
        for element in resources
        if element.tag in (f"{MATERIAL}compositematerials", f"{MATERIAL}multiproperties")
    }
    plain: NDArray[np.uint8] = np.array(options.colour or (255, 255, 255, 255), np.uint8)
    return _Properties(colours, uv, materials, unsupported, plain)


def _transform(path: Path, text: str | None) -> NDArray[np.float64]:
    """3MF row-vector transform ``m00 ... m32`` as a 4x4 column-vector matrix."""
    matrix = np.eye(4)
    if text is None:
        return matrix
    try:
        values = np.array(text.split(), dtype=np.float64)
    except ValueError:
        values = np.array([np.nan])
    if values.shape != (12,) or not np.isfinite(values).all():
        raise InputError(
            path,
            f"has a malformed transform {text!r}",
            "a 3MF transform is 12 numbers (m00 m01 m02 ... m30 m31 m32); re-export it",
        )
    values = values.reshape(4, 3)
    matrix[:3, :3] = values[:3].T
    matrix[:3, 3] = values[3]
    scale = float(np.abs(matrix[:3, :3]).max())
    if scale == 0 or abs(np.linalg.det(matrix[:3, :3])) <= 1e-12 * scale**3:
        raise InputError(
            path,
            f"has a singular transform {text!r} (it flattens the object)",
            "re-export it with an invertible transform",
        )
    return matrix


def _object_meshes(
    path: Path,
    objects: dict[str, ElementTree.Element],
    object_id: str,
    transform: NDArray[np.float64],
    properties: _Properties,
    depth: int,
) -> list[dict[str, NDArray[np.generic]]]:
    if depth > 32 or object_id not in objects:
        raise InputError(path, f"references missing or cyclic object {object_id!r}", "re-export it")
    obj = objects[object_id]
    mesh = obj.find(f"{CORE}mesh")
    parts: list[dict[str, NDArray[np.generic]]] = []
    if mesh is not None:
        parts.append(_mesh_part(path, obj, mesh, transform, properties))
    components = obj.find(f"{CORE}components")
    if components is not None:
        for component in components.iter(f"{CORE}component"):
            child = transform @ _transform(path, component.get("transform"))
            parts += _object_meshes(
                path, objects, component.get("objectid", ""), child, properties, depth + 1
            )
    return parts


def _mesh_part(
    path: Path,
    obj: ElementTree.Element,
    mesh: ElementTree.Element,
    transform: NDArray[np.float64],
    properties: _Properties,
) -> dict[str, NDArray[np.generic]]:
    coordinates = [v.get(k, "nan") for v in mesh.iter(f"{CORE}vertex") for k in "xyz"]
    vertices = _numbers(path, "vertex coordinate", coordinates, float).astype(np.float64)
    vertices = vertices.reshape(-1, 3)
    triangles = list(mesh.iter(f"{CORE}triangle"))
    corners = [t.get(k, "-1") for t in triangles for k in ("v1", "v2", "v3")]
    faces = _numbers(path, "vertex index", corners, int).astype(np.int64).reshape(-1, 3)
    if len(vertices) == 0 or len(faces) == 0:
        raise InputError(path, f"object {obj.get('id')} has an empty mesh", "re-export it")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputError(
            path, f"object {obj.get('id')} has a vertex index out of range", "re-export it"
        )
    if not np.isfinite(vertices).all():
        bad = int((~np.isfinite(vertices)).any(axis=1).sum())
        raise InputError(
            path,
            f"object {obj.get('id')} has {bad} vertices with NaN or infinite coordinates",
            "fix or re-export the model",
        )
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused by load_model
        vertices = vertices @ transform[:3, :3].T + transform[:3, 3]
    default_pid, default_index = obj.get("pid", ""), obj.get("pindex", "")
    pid = np.array([t.get("pid", default_pid) for t in triangles], dtype=object)
    p1 = [t.get("p1", default_index if t.get("pid") is None else "") for t in triangles]
    indices = [
        str(value)
        for a, t in zip(p1, triangles, strict=True)
        for value in (a or -1, t.get("p2", a or -1), t.get("p3", a or -1))
    ]
    index = _numbers(path, "property index", indices, int).astype(np.int64).reshape(-1, 3)
    n = len(faces)
    rgba = np.full((n, 3, 4), 255, dtype=np.uint8)
    uv = np.zeros((n, 3, 2))
    material = np.full(n, -1, dtype=np.int64)
    for group in set(pid.tolist()) - {""}:  # loop over property groups, not faces
        chosen = pid == group
        if group in properties.colours:
            table = properties.colours[group]
            rgba[chosen] = table[_check_index(path, index[chosen], len(table))]
        elif group in properties.uv:
            coords, texture = properties.uv[group]
            uv[chosen] = coords[_check_index(path, index[chosen], len(coords))]
            material[chosen] = texture
        elif group in properties.unsupported:
            rgba[chosen] = properties.fallback
            colour = ",".join(str(c) for c in properties.fallback)
            warnings.warn(
                f"{path}: {int(chosen.sum())} triangles use a <{properties.unsupported[group]}> "
                f"property group ({group!r}), which shellvox does not read; they get "
                f"{colour} (white, or --colour)",
                ShellvoxWarning,
                stacklevel=5,
            )
        else:
            raise InputError(
                path, f"triangles reference unknown property group {group!r}", "re-export it"
            )
    coloured = pid != ""
    return {
        "vertices": vertices,
        "faces": faces,
        "rgba": rgba,
        "uv": uv,
        "material": material,
        "coloured": coloured.astype(bool),
    }


def _check_index(path: Path, index: NDArray[np.int64], size: int) -> NDArray[np.int64]:
    if index.min() < 0 or index.max() >= size:
        raise InputError(path, "a triangle's property index is out of range", "re-export it")
    return index


def _combine(
    path: Path, parts: list[dict[str, NDArray[np.generic]]], materials: list[Material]
) -> ColouredMesh:
    offsets = np.cumsum([0] + [len(p["vertices"]) for p in parts[:-1]])
    vertices = np.concatenate([p["vertices"] for p in parts]).astype(np.float64)
    faces = np.concatenate([p["faces"] + o for p, o in zip(parts, offsets, strict=True)])
    rgba = np.concatenate([p["rgba"] for p in parts]).astype(np.uint8)
    uv = np.concatenate([p["uv"] for p in parts]).astype(np.float64)
    material = np.concatenate([p["material"] for p in parts]).astype(np.int64)
    coloured = np.concatenate([p["coloured"] for p in parts]).astype(bool)
    source = str(path)
    if (material >= 0).any():
        # Untextured triangles keep their colour as a plain material of that colour.
        plain = material < 0
        colours, inverse = np.unique(rgba[plain, 0], axis=0, return_inverse=True)
        table = list(materials) + [Material("colour", factor=decode_uint8(c)) for c in colours]
        material[plain] = len(materials) + inverse.reshape(-1)
        return ColouredMesh(
            vertices,
            faces,
            "texture",
            corner_uv=uv,
            face_material=material,
            materials=tuple(table),
            source=source,
        )
    if not coloured.any():
        return ColouredMesh(vertices, faces, "none", source=source)
    if (rgba == rgba[:, :1]).all():
        return ColouredMesh(vertices, faces, "face", face_rgba=rgba[:, 0].copy(), source=source)
    return ColouredMesh(vertices, faces, "vertex", corner_rgba=rgba, source=source)
