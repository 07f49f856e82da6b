"""Wavefront MTL material libraries of an OBJ, and the files they name.

``newmtl`` blocks give a ``Kd`` colour (with ``d``/``Tr``) and a ``map_Kd`` texture (with
its ``-clamp`` option; ``-o/-s/-t`` are refused with a warning). Files named in an OBJ or
MTL (``mtllib``, ``map_Kd``) are found under the path policy of
:mod:`shellvox.loading._references` (see :mod:`shellvox.loading.obj._reader`); textures are read
under one pixel budget (:mod:`shellvox.loading._images`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, opt, warn
from shellvox.loading._images import TextureRef, read_textures
from shellvox.loading._references import check_inside, is_file, is_inside
from shellvox.model import Material, WrapMode
from shellvox.voxel.colour import srgb_to_linear

#: Fix for an OBJ texture that cannot be used.
TEXTURE_FIX = f"put the image beside the MTL, or pass {opt('texture', cli='FILE')}"


@dataclass(frozen=True)
class MtlEntry:
    """One ``newmtl`` block: its ``Kd``/``d`` colour and ``map_Kd`` statement."""

    name: str
    mtl: Path
    factor: NDArray[np.float64]  # (4,) linear RGB + alpha from Kd and d/Tr
    texture: str | None  # map_Kd file name, options removed
    wrap: tuple[WrapMode, WrapMode]


def statement(raw: str) -> tuple[str, str]:
    """Split an OBJ/MTL line into its keyword and the rest (spaces or tabs between)."""
    parts = raw.strip().split(None, 1)
    if not parts or parts[0].startswith("#"):
        return "", ""
    return parts[0], parts[1].strip() if len(parts) > 1 else ""


def resolve(
    model: Path, base: Path, name: str, what: str, *, force: bool, alternative: str = ""
) -> Path | None:
    """Find a file named in an OBJ/MTL, under the path policy; None when it is missing.

    Spaces, tabs, quotes, backslashes and letter case are forgiven; a name pointing out
    of the OBJ's folder is looked for by its file name in ``base`` first.
    """
    cleaned = name.strip().strip('"').replace("\\", "/")
    declared = base / cleaned
    if is_file(declared) and is_inside(model.parent, declared):
        return declared
    local = base / Path(cleaned).name
    if is_file(local) and is_inside(model.parent, local):
        return local
    wanted = Path(cleaned).name.lower()
    if base.is_dir():
        for entry in sorted(base.iterdir()):
            if entry.name.lower() == wanted and entry.is_file() and is_inside(model.parent, entry):
                return entry
    if is_file(declared):  # only the file outside the folder exists
        return check_inside(model, declared, what, force=force, alternative=alternative)
    return None


def read_materials(path: Path, mtllibs: list[str], options: LoadOptions) -> dict[str, MtlEntry]:
    """Read the MTL libraries an OBJ names; apply the missing-MTL rules."""
    found: list[Path] = []
    missing: list[str] = []
    for name in mtllibs:
        what = f"material library {name!r}"
        mtl = resolve(path, path.parent, name, what, force=options.force)
        if mtl is None and len(name.split()) > 1:  # "mtllib a.mtl b.mtl"
            parts = [resolve(path, path.parent, n, what, force=options.force) for n in name.split()]
            if all(p is not None for p in parts):
                found += [p for p in parts if p is not None]
                continue
        if mtl is None:
            missing.append(name)
        else:
            found.append(mtl)
    if missing and found:
        warn(
            f"{path}: material library {missing[0]!r} is missing; the materials of "
            f"{', '.join(repr(f.name) for f in found)} are used",
        )
    elif missing:
        if options.texture is not None or options.colour is not None:
            warn(
                f"{path}: MTL file {missing[0]!r} not found; using the "
                f"{opt('texture')} or {opt('colour')} given instead",
            )
            return {}
        raise InputError(
            path,
            f"its material library {missing[0]!r} is missing",
            f"put the MTL beside the OBJ, or pass {opt('texture', cli='FILE')} or {opt('colour')}",
        )
    entries: dict[str, MtlEntry] = {}
    for mtl in found:
        entries.update(_parse_mtl(mtl))
    return entries


def _parse_mtl(mtl: Path) -> dict[str, MtlEntry]:
    """Parse one MTL file's ``newmtl`` blocks (``Kd``, ``d``/``Tr``, ``map_Kd``)."""
    blocks: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    for raw in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
        key, rest = statement(raw)
        if key == "newmtl":
            current = blocks.setdefault(rest, {})
        elif key and current is not None:
            current[key.lower()] = rest
    entries: dict[str, MtlEntry] = {}
    for name, block in blocks.items():
        alpha = 1.0
        if "d" in block:
            alpha = _number(mtl, name, "d", block["d"])
        elif "tr" in block:
            alpha = 1.0 - _number(mtl, name, "Tr", block["tr"])
        kd = _kd(mtl, name, block.get("kd", "1 1 1"))
        texture, wrap = _map_statement(mtl, name, block.get("map_kd"))
        factor = np.append(srgb_to_linear(np.clip(kd, 0.0, 1.0)), np.clip(alpha, 0.0, 1.0))
        entries[name] = MtlEntry(name, mtl, factor, texture, wrap)
    return entries


def _number(mtl: Path, material: str, key: str, value: str, token: str | None = None) -> float:
    """Parse ``token`` (default the last word of ``value``) of an MTL statement as a number."""
    words = value.split()
    text = token if token is not None else (words[-1] if words else "")
    try:
        number = float(text)
    except ValueError:
        number = float("nan")
    if not np.isfinite(number):
        raise InputError(
            mtl,
            f"material {material!r} has a malformed '{key}' value {value!r}",
            "write numbers (e.g. 'Kd 0.8 0.2 0.1') and export it again",
        )
    return number


def _kd(mtl: Path, material: str, value: str) -> NDArray[np.float64]:
    """``Kd r [g b]`` as three numbers; ``Kd spectral``/``Kd xyz`` give white, with a warning."""
    tokens = value.split()
    if tokens and tokens[0].lower() in ("spectral", "xyz"):
        warn(
            f"{mtl}: material {material!r} gives its Kd as '{tokens[0]}', which shellvox "
            "does not read; its faces are white",
        )
        return np.ones(3)
    if len(tokens) == 1:  # "Kd r" means a grey r r r
        tokens = tokens * 3
    if len(tokens) < 3:
        _number(mtl, material, "Kd", value, "")  # raises: not three numbers
    return np.array([_number(mtl, material, "Kd", value, t) for t in tokens[:3]], np.float64)


#: ``map_Kd`` options and how many arguments they take (``-o``/``-s``/``-t``: 1 to 3).
_MAP_OPTIONS = {
    "-blendu": 1,
    "-blendv": 1,
    "-bm": 1,
    "-boost": 1,
    "-cc": 1,
    "-clamp": 1,
    "-imfchan": 1,
    "-mm": 2,
    "-o": 3,
    "-s": 3,
    "-t": 3,
    "-texres": 1,
    "-type": 1,
}
_IDENTITY = {"-o": 0.0, "-s": 1.0, "-t": 0.0}


def _map_statement(
    mtl: Path, material: str, value: str | None
) -> tuple[str | None, tuple[WrapMode, WrapMode]]:
    """Split a ``map_Kd`` value into the file name (spaces kept) and the wrap rule.

    ``-clamp on`` gives clamped texture coordinates; ``-o``, ``-s`` and ``-t`` other than
    the identity are not applied, with a warning; other options do not change colour.
    """
    wrap: tuple[WrapMode, WrapMode] = ("repeat", "repeat")
    if value is None:
        return None, wrap
    rest = value.strip()
    while (match := re.match(r"(-[A-Za-z]+)\s+", rest)) and match[1].lower() in _MAP_OPTIONS:
        option = match[1].lower()
        rest = rest[match.end() :]
        arguments: list[str] = []
        for _ in range(_MAP_OPTIONS[option]):
            token = rest.split(None, 1)
            if not token or (option in _IDENTITY and arguments and not _is_number(token[0])):
                break
            arguments.append(token[0])
            rest = token[1] if len(token) > 1 else ""
        if option == "-clamp" and arguments[:1] == ["on"]:
            wrap = ("clamp", "clamp")
        if option in _IDENTITY and any(
            not _is_number(a) or float(a) != _IDENTITY[option] for a in arguments
        ):
            warn(
                f"{mtl}: material {material!r}: map_Kd option {option} "
                f"{' '.join(arguments)} is not applied (the texture is used unshifted and "
                "unscaled); bake it into the UVs to keep it",
            )
    return rest.strip() or None, wrap


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def fallback_factor(options: LoadOptions) -> NDArray[np.float64]:
    """Linear RGBA of ``--colour``, or white, for faces without a usable material."""
    if options.colour is None:
        return np.ones(4)
    values = np.asarray(options.colour, dtype=np.float64) / 255.0
    return np.append(srgb_to_linear(values[:3]), values[3])


def texture_materials(
    path: Path,
    entries: dict[str, MtlEntry],
    textured: list[str],
    used: list[str],
    options: LoadOptions,
) -> tuple[dict[str, Material], bool]:
    """Return the materials of the used names and whether ``--texture`` was used.

    Textures are read under one pixel budget; ``--texture`` replaces every texture
    that is missing, or textures every face when there is no MTL.
    """
    refs: list[TextureRef] = []
    if not entries:  # no MTL: --texture on every face
        assert options.texture is not None
        refs.append(TextureRef(path, opt("texture", str(options.texture)), options.texture))
        images = read_textures(refs, colour=options.colour, force=options.force)
        image = images[0]
        if image is None:
            return {"": Material("texture", factor=fallback_factor(options))}, True
        return {"": Material("texture", image=image)}, True
    for name in textured:
        entry = entries[name]
        assert entry.texture is not None
        what = f"texture {entry.texture!r} of material {name!r}"
        source = resolve(
            path,
            entry.mtl.parent,
            entry.texture,
            what,
            force=options.force,
            alternative=f"pass {opt('texture', cli='FILE')}",
        )
        if source is None and options.texture is not None:
            source = options.texture
        refs.append(TextureRef(entry.mtl, what, source, TEXTURE_FIX))
    images = read_textures(refs, colour=options.colour, force=options.force)
    table: dict[str, Material] = {}
    for name, image in zip(textured, images, strict=True):
        if image is None:
            table[name] = Material(name, factor=fallback_factor(options))
        else:
            table[name] = Material(name, image=image, wrap=entries[name].wrap)
    for name in used:
        if name not in table:
            factor = entries[name].factor if name in entries else fallback_factor(options)
            table[name] = Material(name or "default", factor=factor)
    return table, any(ref.source is options.texture for ref in refs)
