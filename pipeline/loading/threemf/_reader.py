"""3MF reader (core, materials and production extensions, slicer paint) from the XML.

trimesh reads 3MF geometry but drops colour groups and textures, and lib3mf does not
give the slicers' paint attributes, so the package's XML is read here
(:mod:`shellvox.loading.threemf._package` checks the archive first): the model ``unit``,
build items, components and their transforms, including components and items in other
model parts (Production extension ``p:path``, as Bambu Studio and OrcaSlicer write
them; only the root part may refer to other parts); per triangle or per corner the
property groups of :mod:`shellvox.loading.threemf._properties` (colour groups, base and
composite materials, textures, multiproperties); and multi-material paint of PrusaSlicer,
Bambu Studio and OrcaSlicer with the project's filament colours
(:mod:`shellvox.loading.threemf._slicer_paint`, :mod:`shellvox.loading.threemf._paint_tree`).
Anything malformed (XML, zip CRC, colour strings, transforms, numbers, references) is an
:class:`~shellvox.errors.InputError`.

Reference: 3MF Core Specification 1.3, Materials and Properties Extension 1.2,
Production Extension 1.2.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from shellvox.config import UNIT_MM, LoadOptions
from shellvox.errors import InputError, opt, warn
from shellvox.loading._combine import corner_colour_mesh, stack_parts
from shellvox.loading._images import MAX_TEXTURE_PIXELS
from shellvox.loading.threemf._attributes import check_index, transform_matrix, triangle_properties
from shellvox.loading.threemf._multi import Layered, bake
from shellvox.loading.threemf._package import check_archive, parse_xml, root_model_part
from shellvox.loading.threemf._properties import (
    CORE,
    Properties,
    parse_numbers,
    read_properties,
)
from shellvox.loading.threemf._slicer_paint import PAINT_ATTRIBUTES, paint_parts, read_project
from shellvox.model import ColouredMesh, Material
from shellvox.voxel.colour import decode_uint8

PRODUCTION = "{http://schemas.microsoft.com/3dmanufacturing/production/2015/06}"
UNITS_3MF = {
    "micron": "micron",
    "millimeter": "mm",
    "centimeter": "cm",
    "inch": "inch",
    "foot": "foot",
    "meter": "m",
}

Part = dict[str, Any]


@dataclass
class _ModelPart:
    """One model part of the package: its objects and property groups."""

    name: str
    objects: dict[str, ElementTree.Element]
    properties: Properties


class _Package:
    """The open package: its model parts (read on first use) and baked textures."""

    def __init__(self, path: Path, archive: zipfile.ZipFile, options: LoadOptions) -> None:
        self.path, self.archive, self.options = path, archive, options
        self.root_name = root_model_part(path, archive)
        self.materials: list[Material] = []
        self.parts: dict[str, _ModelPart] = {}
        self.baked: dict[tuple[str, str, bytes], int] = {}
        self.baked_pixels = 0
        self.averaged = 0

    def part(self, name: str, root: ElementTree.Element | None = None) -> _ModelPart:
        if name not in self.parts:
            root = parse_xml(self.path, self.archive, name) if root is None else root
            resources = root.find(f"{CORE}resources")
            if resources is None:
                raise InputError(self.path, f"{name} has no <resources>", "re-export it as 3MF")
            objects = {obj.get("id", ""): obj for obj in resources.iter(f"{CORE}object")}
            properties = read_properties(
                self.path, self.archive, resources, self.options, self.materials
            )
            self.parts[name] = _ModelPart(name, objects, properties)
        return self.parts[name]

    def resolve(self, reference: str, within: str) -> str:
        """Return the part a ``p:path`` names (only the root part may name others)."""
        if within != self.root_name:
            raise InputError(
                self.path,
                f"model part {within} refers to another model part ({reference})",
                "only the root model part may use p:path; re-export it",
            )
        name = reference.replace("\\", "/").lstrip("/")
        if name not in self.archive.namelist():
            raise InputError(
                self.path, f"p:path refers to a missing model part {reference!r}", "re-export it"
            )
        return name

    def bake(self, part: str, group: str, layered: Layered, constants: NDArray[np.float64]) -> int:
        """Index of the material baking ``layered``'s texture under these other layers."""
        key = (part, group, constants.tobytes())
        if key not in self.baked:
            source = self.materials[layered.texture]
            if source.image is None:  # replaced by --colour: nothing to blend
                return layered.texture
            self.baked_pixels += source.image.shape[0] * source.image.shape[1]
            if self.baked_pixels > MAX_TEXTURE_PIXELS and not self.options.force:
                raise InputError(
                    self.path,
                    f"multiproperties {group!r} need {self.baked_pixels:,} texture pixels "
                    f"baked, more than the limit of {MAX_TEXTURE_PIXELS:,}",
                    f"pass {opt('force')}",
                )
            image = bake(
                source.image,
                constants,
                layered.texture_layer,
                layered.methods,
                material_first=layered.material_first,
            )
            material = Material(
                f"{source.name} in multiproperties {group!r}",
                image=image,
                wrap=source.wrap,
                filter=source.filter,
            )
            self.baked[key] = len(self.materials)
            self.materials.append(material)
        return self.baked[key]


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
    except NotImplementedError as error:  # e.g. an entry needs a newer zip version
        raise InputError(
            path, f"is a zip archive that cannot be read ({error})", "re-export it as 3MF"
        ) from None
    with archive:
        check_archive(path, archive)
        package = _Package(path, archive, options)
        root = parse_xml(path, archive, package.root_name)
        unit = root.get("unit", "millimeter")
        if unit not in UNITS_3MF:
            raise InputError(
                path, f"declares unknown unit {unit!r}", f"use one of {', '.join(UNITS_3MF)}"
            )
        package.part(package.root_name, root)
        project = read_project(path, archive)
        parts: list[Part] = []
        build = root.find(f"{CORE}build")
        for item in [] if build is None else build.iter(f"{CORE}item"):
            name = package.root_name
            if item.get(f"{PRODUCTION}path"):
                name = package.resolve(str(item.get(f"{PRODUCTION}path")), name)
            transform = transform_matrix(path, item.get("transform"))
            parts += _object_meshes(package, name, item.get("objectid", ""), transform, (), 0)
    if package.averaged:
        warn(
            f"{path}: {package.averaged} textured multiproperties triangles have different "
            "colours under the texture at their corners; each gets their mean",
        )
    parts = paint_parts(path, parts, project)
    if not parts:
        raise InputError(path, "has no build items with meshes", "re-export it with geometry")
    return _combine(path, parts, package.materials), UNIT_MM[UNITS_3MF[unit]]


def _object_meshes(
    package: _Package,
    part_name: str,
    object_id: str,
    transform: NDArray[np.float64],
    trail: tuple[str, ...],
    depth: int,
) -> list[Part]:
    path = package.path
    part = package.part(part_name)
    if depth > 32 or object_id not in part.objects:
        problem = f"references missing or cyclic object {object_id!r} in {part_name}"
        raise InputError(path, problem, "re-export it")
    obj = part.objects[object_id]
    trail = (*trail, object_id)
    mesh = obj.find(f"{CORE}mesh")
    parts: list[Part] = []
    if mesh is not None:
        parts.append(_mesh_part(package, part, obj, mesh, transform, trail))
    components = obj.find(f"{CORE}components")
    if components is not None:
        for component in components.iter(f"{CORE}component"):
            child = transform @ transform_matrix(path, component.get("transform"))
            name = part_name
            if component.get(f"{PRODUCTION}path"):
                name = package.resolve(str(component.get(f"{PRODUCTION}path")), part_name)
            parts += _object_meshes(
                package, name, component.get("objectid", ""), child, trail, depth + 1
            )
    return parts


def _mesh_part(
    package: _Package,
    part: _ModelPart,
    obj: ElementTree.Element,
    mesh: ElementTree.Element,
    transform: NDArray[np.float64],
    trail: tuple[str, ...],
) -> Part:
    path, properties = package.path, part.properties
    coordinates = [v.get(k, "nan") for v in mesh.iter(f"{CORE}vertex") for k in "xyz"]
    vertices = parse_numbers(path, "vertex coordinate", coordinates, float).astype(np.float64)
    vertices = vertices.reshape(-1, 3)
    triangles = list(mesh.iter(f"{CORE}triangle"))
    corners = [t.get(k, "-1") for t in triangles for k in ("v1", "v2", "v3")]
    faces = parse_numbers(path, "vertex index", corners, int).astype(np.int64).reshape(-1, 3)
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
    pid, index = triangle_properties(path, obj, triangles)
    n = len(faces)
    rgba = np.full((n, 3, 4), 255, dtype=np.uint8)
    uv = np.zeros((n, 3, 2))
    material = np.full(n, -1, dtype=np.int64)
    for group in set(pid.tolist()) - {""}:  # loop over property groups, not faces
        chosen = pid == group
        if group in properties.colours:
            table = properties.colours[group]
            rgba[chosen] = table[check_index(path, index[chosen], len(table))]
        elif group in properties.uv:
            coords, texture = properties.uv[group]
            uv[chosen] = coords[check_index(path, index[chosen], len(coords))]
            material[chosen] = texture
        elif group in properties.layered:
            layered = properties.layered[group]
            corner = check_index(path, index[chosen], len(layered.uv))
            uv[chosen], material[chosen] = _layered(package, part.name, group, layered, corner)
        else:
            raise InputError(
                path, f"triangles reference unknown property group {group!r}", "re-export it"
            )
    paint = None
    if any(a in t.attrib for t in triangles for a in PAINT_ATTRIBUTES):
        paint = [t.get(PAINT_ATTRIBUTES[0]) or t.get(PAINT_ATTRIBUTES[1]) or "" for t in triangles]
    return {
        "vertices": vertices,
        "faces": faces,
        "rgba": rgba,
        "uv": uv,
        "material": material,
        "coloured": pid != "",
        "paint": paint,
        "trail": trail,
    }


def _layered(
    package: _Package, part: str, group: str, layered: Layered, corner: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """UVs ``(n, 3, 2)`` and baked material ``(n,)`` of triangles of a textured group."""
    constants = layered.constants[corner]  # (n, 3, L, 4)
    differ = (constants != constants[:, :1]).any(axis=(1, 2, 3))
    package.averaged += int(differ.sum())
    mean = constants.mean(axis=1)  # linear light
    keys, inverse = np.unique(mean.reshape(len(mean), -1), axis=0, return_inverse=True)
    table = np.array(
        [package.bake(part, group, layered, key.reshape(-1, 4)) for key in keys], np.int64
    )  # loop over distinct layer colours
    return layered.uv[corner], table[inverse.reshape(-1)]


def _combine(path: Path, parts: list[Part], materials: list[Material]) -> ColouredMesh:
    vertices, faces = stack_parts(parts)
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
    return corner_colour_mesh(source, vertices, faces, rgba)
