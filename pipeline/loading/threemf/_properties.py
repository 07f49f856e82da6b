"""The property groups of one 3MF model part: colours, materials, textures, layers.

Read from the part's ``<resources>`` (3MF Core 1.3 and Materials and Properties
Extension 1.2): ``<colorgroup>`` and ``<basematerials>`` (display colours) as colour
tables; ``<compositematerials>`` as the colour table of their mixtures (below);
``<texture2d>`` with ``<texture2dgroup>`` coordinates; ``<multiproperties>`` blended by
:mod:`shellvox.loading.threemf._multi` into a colour table, or, with a texture layer,
kept as a :class:`~shellvox.loading.threemf._multi.Layered` group to be baked.

A composite's colour is the mixture of its base materials' ``displaycolor`` in the
composite's proportions (normalised as the spec says), mixed in linear light. A
:class:`~shellvox.model._mesh.ColouredMesh` has no place for per-face material ratios, so only
that colour is used, and the user is told so in a warning.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, warn
from shellvox.loading._images import TextureRef, read_textures
from shellvox.loading.threemf._multi import Layered, blend_methods, colour_table
from shellvox.loading.threemf._package import read_entry
from shellvox.model import FilterMode, Material, WrapMode
from shellvox.voxel.colour import decode_uint8, encode_uint8

CORE = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
MATERIAL = "{http://schemas.microsoft.com/3dmanufacturing/material/2015/02}"
FIX = "re-export it as 3MF"
WRAP_3MF: dict[str, WrapMode] = {
    "wrap": "repeat",
    "mirror": "mirror",
    "clamp": "clamp",
    "none": "clamp",
}


@dataclass
class Properties:
    """Property groups of one model part, by id.

    Parameters
    ----------
    colours : dict of str to (n, 4) uint8
        sRGB + alpha per index: colour groups, base materials, composites and
        colour-only multiproperties.
    uv : dict of str to ((n, 2) float64, int)
        Texture coordinates per index and the texture's index in ``materials``.
    layered : dict of str to Layered
        Multiproperties with a texture layer.
    materials : list of Material
        The model's materials (shared by all parts); textures are appended here.
    """

    colours: dict[str, NDArray[np.uint8]]
    uv: dict[str, tuple[NDArray[np.float64], int]]
    layered: dict[str, Layered]
    materials: list[Material]


def parse_colour(path: Path, value: str | None) -> NDArray[np.uint8]:
    """Parse ``#RRGGBB`` or ``#RRGGBBAA`` as ``(4,) uint8`` sRGB + alpha."""
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


def parse_numbers(path: Path, what: str, values: list[str], dtype: type) -> NDArray[np.generic]:
    """Parse XML attribute strings as numbers, or refuse naming what they are."""
    try:
        array: NDArray[np.generic] = np.array(values, dtype=np.str_).astype(dtype)
    except OverflowError:  # an integer beyond int64
        raise InputError(path, f"has a {what} out of range (beyond 64 bits)", FIX) from None
    except ValueError:
        bad = next((v for v in values if not _parses(v, dtype)), "?")
        raise InputError(path, f"has a non-numeric {what} {bad!r}", FIX) from None
    return array


def _parses(value: str, dtype: type) -> bool:
    try:
        dtype(value)
    except ValueError:
        return False
    return True


def read_properties(
    path: Path,
    archive: zipfile.ZipFile,
    resources: ElementTree.Element,
    options: LoadOptions,
    materials: list[Material],
) -> Properties:
    """Read the property groups of one model part's ``<resources>``.

    Parameters
    ----------
    path : Path
        The package, for messages.
    archive : zipfile.ZipFile
        The package, for texture entries.
    resources : Element
        The part's ``<resources>``.
    options : LoadOptions
        ``colour`` replaces a missing texture; ``force`` lifts the pixel budget.
    materials : list of Material
        The model's material list; this part's textures are appended.

    Returns
    -------
    Properties
    """
    colours: dict[str, NDArray[np.uint8]] = {}
    for group in resources.iter(f"{MATERIAL}colorgroup"):
        colours[group.get("id", "")] = np.array(
            [parse_colour(path, c.get("color")) for c in group.iter(f"{MATERIAL}color")],
            np.uint8,
        ).reshape(-1, 4)
    bases = set()
    for group in resources.iter(f"{CORE}basematerials"):
        bases.add(group.get("id", ""))
        colours[group.get("id", "")] = np.array(
            [parse_colour(path, b.get("displaycolor")) for b in group.iter(f"{CORE}base")],
            np.uint8,
        ).reshape(-1, 4)
    composites = list(resources.iter(f"{MATERIAL}compositematerials"))
    for group in composites:
        colours[group.get("id", "")] = _composite_colours(path, group, colours, bases)
    if composites:
        warn(
            f"{path}: <compositematerials> mixing ratios are printed as their display colour "
            "(the base materials' display colours mixed in those ratios); shellvox keeps no "
            "per-face material ratios",
        )
    uv = _texture_groups(path, archive, resources, options, materials)
    properties = Properties(colours, uv, {}, materials)
    material_ids = bases | {g.get("id", "") for g in composites}
    for group in resources.iter(f"{MATERIAL}multiproperties"):
        _multiproperties(path, group, properties, material_ids)
    return properties


def _composite_colours(
    path: Path, group: ElementTree.Element, colours: dict[str, NDArray[np.uint8]], bases: set[str]
) -> NDArray[np.uint8]:
    """Display colour of each ``<composite>``: its base materials mixed in linear light."""
    name = group.get("id")
    matid = group.get("matid", "")
    if matid not in bases:
        raise InputError(
            path, f"composite materials {name!r} refer to unknown base materials {matid!r}", FIX
        )
    indices = parse_numbers(path, "material index", (group.get("matindices") or "").split(), int)
    table = colours[matid]
    if len(indices) == 0 or indices.min() < 0 or indices.max() >= len(table):
        raise InputError(
            path, f"composite materials {name!r} have a material index out of range", FIX
        )
    rows = []
    for composite in group.iter(f"{MATERIAL}composite"):
        values = parse_numbers(
            path, "composite value", (composite.get("values") or "").split(), float
        ).astype(np.float64)[: len(indices)]
        rows.append(np.pad(values, (0, len(indices) - len(values))))
    ratios = np.array(rows, dtype=np.float64).reshape(-1, len(indices))
    if not np.isfinite(ratios).all() or (ratios < 0).any():
        raise InputError(path, f"composite materials {name!r} have a negative ratio", FIX)
    total = ratios.sum(axis=1, keepdims=True)
    ratios = np.where(total > 0, ratios / np.where(total > 0, total, 1), 1.0 / len(indices))
    return encode_uint8(ratios @ decode_uint8(table[indices]))


def _texture_groups(
    path: Path,
    archive: zipfile.ZipFile,
    resources: ElementTree.Element,
    options: LoadOptions,
    materials: list[Material],
) -> dict[str, tuple[NDArray[np.float64], int]]:
    textures: dict[str, int] = {}
    elements = list(resources.iter(f"{MATERIAL}texture2d"))
    entries = set(archive.namelist())
    refs = []
    for texture in elements:
        name = (texture.get("path") or "").lstrip("/")
        data = read_entry(path, archive, name) if name in entries else None
        refs.append(TextureRef(path, f"texture {name!r} (in the package)", data, "re-export it"))
    images = read_textures(refs, colour=options.colour, force=options.force)
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
                FIX,
            )
        values = [c.get(k, "0") for c in group.iter(f"{MATERIAL}tex2coord") for k in "uv"]
        coords = parse_numbers(path, "texture coordinate", values, float).reshape(-1, 2)
        uv[group.get("id", "")] = (coords.astype(np.float64), textures[texid])
    return uv


def _multiproperties(
    path: Path, group: ElementTree.Element, properties: Properties, material_ids: set[str]
) -> None:
    """Add one ``<multiproperties>`` group to ``properties`` (a colour table or layered)."""
    name = group.get("id", "")
    pids = (group.get("pids") or "").split()
    unknown = [p for p in pids if p not in properties.colours and p not in properties.uv]
    if not pids or unknown:
        raise InputError(
            path,
            f"multiproperties {name!r} layer unknown property groups {unknown or pids!r}",
            "its pids must name colour groups, materials or texture groups; " + FIX,
        )
    methods = blend_methods(group.get("blendmethods"), len(pids))
    if methods is None:
        raise InputError(
            path,
            f"multiproperties {name!r} have malformed blendmethods {group.get('blendmethods')!r}",
            f"give at most {len(pids) - 1} of mix or multiply; " + FIX,
        )
    entries = [child for child in group if child.tag in (f"{MATERIAL}multi", f"{CORE}multi")]
    if not entries:
        raise InputError(
            path,
            f"multiproperties {name!r} have no <multi> entries",
            "give each layer combination a <m:multi pindices=...> entry; " + FIX,
        )
    if any(child.tag == f"{CORE}multi" for child in entries):
        warn(
            f"{path}: multiproperties {name!r} write their entries as <multi> in the core "
            "namespace, not the Materials extension's <m:multi>; shellvox reads them as "
            "<m:multi> (lib3mf reads the group as empty)",
        )
    rows = []
    for multi in entries:
        words = (multi.get("pindices") or "").split()[: len(pids)]
        rows.append(words + ["0"] * (len(pids) - len(words)))
    flat = [w for row in rows for w in row]
    indices = parse_numbers(path, "property index", flat, int).astype(np.int64)
    indices = indices.reshape(-1, len(pids))
    sizes = [
        len(properties.colours[p]) if p in properties.colours else len(properties.uv[p][0])
        for p in pids
    ]
    if len(indices) and ((indices < 0) | (indices >= np.array(sizes))).any():
        raise InputError(path, f"multiproperties {name!r} have an index out of range", FIX)
    textured = [k for k, p in enumerate(pids) if p in properties.uv]
    if len(textured) > 1:
        warn(
            f"{path}: multiproperties {name!r} layer {len(textured)} textures; shellvox "
            f"reads the first (group {pids[textured[0]]!r}) and leaves out the others",
        )
        keep = [k for k in range(len(pids)) if k not in textured[1:]]
        methods = tuple(methods[k - 1] for k in keep[1:])
        pids, indices = [pids[k] for k in keep], indices[:, keep]
    material_first = pids[0] in material_ids
    if not textured:
        tables = [properties.colours[p] for p in pids]
        properties.colours[name] = colour_table(
            tables, indices, methods, material_first=material_first
        )
        return
    layer = textured[0]
    coords, texture = properties.uv[pids[layer]]
    constants = np.zeros((len(indices), len(pids), 4))
    for k, pid in enumerate(pids):  # loop over layers
        if k != layer:
            constants[:, k] = decode_uint8(properties.colours[pid][indices[:, k]])
    properties.layered[name] = Layered(
        coords[indices[:, layer]], texture, constants, layer, methods, material_first
    )
