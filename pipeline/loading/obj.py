"""Wavefront OBJ + MTL reader: positions, per-corner UVs, materials, vertex colours.

Written here rather than taken from trimesh so that per-face materials stay distinct, MTL
texture paths with spaces, tabs or Windows backslashes resolve, and a missing MTL or
texture is an error (or, if the user asked, a warning and a fallback) instead of silent
grey. Statements may be separated by spaces or tabs (MeshLab writes
``newmtl<TAB>name<TAB><TAB>`` and ``map_Kd<TAB>file with spaces.png``).

Referenced files (``mtllib``, ``map_Kd``) follow the path policy of
:mod:`pipeline.loading.references`: they must lie in the OBJ's folder or below it. A name
that points elsewhere (an absolute path written by the exporter, ``../textures/x.png``)
is first looked for by its file name in the MTL's folder; if only the outside file
exists, the model is refused unless ``--force`` is given (then it is read, with a
warning), or ``--texture FILE`` names the image to use.

Colour sources, richest first: ``map_Kd`` textures (with ``vt`` on every face), ``v x y z
r g b`` vertex colours, ``Kd`` face colours. A declared colour that cannot be used (a
texture without ``vt``, vertex colours beside textures, a ``usemtl`` name the MTL lacks,
``Kd spectral``/``Kd xyz``, ``map_Kd -o/-s/-t``) gives a one-line warning saying what is
used instead.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.config import LoadOptions
from pipeline.errors import InputError, ShellvoxWarning
from pipeline.loading.images import TextureRef, read_textures
from pipeline.loading.references import check_inside, is_inside
from pipeline.mesh import ColouredMesh
from pipeline.texture import Material, WrapMode
from voxel.srgb import encode_uint8, srgb_to_linear

#: Fix for an OBJ texture that cannot be used.
TEXTURE_FIX = "put the image beside the MTL, or pass --texture FILE"


@dataclass(frozen=True)
class _MtlEntry:
    """One ``newmtl`` block: its ``Kd``/``d`` colour and ``map_Kd`` statement."""

    name: str
    mtl: Path
    factor: NDArray[np.float64]  # (4,) linear RGB + alpha from Kd and d/Tr
    texture: str | None  # map_Kd file name, options removed
    wrap: tuple[WrapMode, WrapMode]


def read_obj(path: Path, options: LoadOptions) -> ColouredMesh:
    """Read an OBJ file (and its MTL and textures) into an unmerged mesh.

    Parameters
    ----------
    path : Path
        The ``.obj`` file.
    options : LoadOptions
        ``texture`` replaces a missing MTL or ``map_Kd``; ``colour`` is the fallback
        colour for a missing texture (with a warning); ``force`` lets referenced files
        outside the OBJ's folder be read (with a warning).

    Returns
    -------
    ColouredMesh
        In file units, vertices not yet merged by position.
    """
    # Tabs separate statements as well as spaces do (MeshLab): one replace over the text
    # keeps the per-line work to a partition.
    text = path.read_text(encoding="utf-8", errors="replace").replace("\t", " ")
    positions: list[str] = []
    uvs: list[str] = []
    face_lines: list[list[str]] = []
    face_material_names: list[str] = []
    mtllibs: list[str] = []
    material = ""
    for raw in text.splitlines():
        key, _, rest = raw.strip().partition(" ")
        if key == "v":
            positions.append(rest)
        elif key == "vt":
            uvs.append(rest)
        elif key == "f":
            face_lines.append(rest.split())
            face_material_names.append(material)
        elif key == "usemtl":
            material = rest.strip()
        elif key == "mtllib":
            mtllibs.append(rest.strip())
    if not positions or not face_lines:
        raise InputError(path, "has no vertices or no faces", "export the mesh with its faces")

    vertex_rows = _parse_rows(path, positions, "v", 3)
    xyz = vertex_rows[:, :3]
    vertex_rgb = vertex_rows[:, 3:6] if vertex_rows.shape[1] >= 6 else None
    uv_rows = _parse_rows(path, uvs, "vt", 1) if uvs else np.zeros((0, 2))
    if uv_rows.shape[1] == 1:  # "vt u": v defaults to 0
        uv_rows = np.concatenate([uv_rows, np.zeros_like(uv_rows)], axis=1)
    uv_rows = uv_rows[:, :2]
    pos_index, uv_index, triangle_owner = _triangulate(path, face_lines, len(xyz), len(uv_rows))
    faces = pos_index
    names = np.asarray(face_material_names, dtype=object)[triangle_owner]
    used = sorted(set(names.tolist()))
    has_uv = uv_index is not None and bool((uv_index >= 0).all())

    entries = _read_materials(path, mtllibs, options)
    _warn_undefined(path, entries, used, names, options)
    textured = [n for n in used if n in entries and entries[n].texture is not None]
    if not has_uv:
        if options.texture is not None:
            raise InputError(
                path,
                "has no texture coordinates ('vt' on every face), so --texture cannot be applied",
                "export the OBJ with UVs, or pass --colour R,G,B instead of --texture",
            )
        if textured:
            warnings.warn(
                f"{path}: material(s) {', '.join(map(repr, textured))} have a texture but "
                "not every face has texture coordinates ('vt'); their Kd colour is used",
                ShellvoxWarning,
                stacklevel=3,
            )
        textured = []
    if textured or (options.texture is not None and not entries):
        assert uv_index is not None
        table, texture_used = _texture_materials(path, entries, textured, used, options)
        if options.texture is not None and not texture_used:
            _warn_texture_unused(path, options.texture, "the MTL's textures were all found")
        if vertex_rgb is not None:
            warnings.warn(
                f"{path}: its vertex colours ('v x y z r g b') are ignored: "
                "the materials' textures colour the faces",
                ShellvoxWarning,
                stacklevel=3,
            )
        if not entries:
            names = np.full(len(faces), "", dtype=object)
            used = [""]
        lookup = {name: i for i, name in enumerate(used)}
        face_material = np.array([lookup[n] for n in names.tolist()], dtype=np.int64)
        if all(table[name].image is None for name in used):  # every texture replaced
            colours = np.array([encode_uint8(table[name].factor) for name in used], np.uint8)
            return ColouredMesh(
                xyz, faces, "face", face_rgba=colours[face_material], source=str(path)
            )
        return ColouredMesh(
            xyz,
            faces,
            "texture",
            corner_uv=uv_rows[uv_index],
            face_material=face_material,
            materials=tuple(table[name] for name in used),
            source=str(path),
        )
    coloured = [n for n in used if n in entries]
    if options.texture is not None:  # has_uv, an MTL, but no map_Kd on the faces
        _warn_texture_unused(path, options.texture, "the MTL gives its faces no map_Kd")
    if vertex_rgb is not None:
        if coloured:
            warnings.warn(
                f"{path}: the Kd colours of material(s) {', '.join(map(repr, coloured))} "
                "are ignored: its vertex colours ('v x y z r g b') colour the faces",
                ShellvoxWarning,
                stacklevel=3,
            )
        rgb = vertex_rgb if vertex_rgb.max() > 1.0 + 1e-9 else vertex_rgb * 255.0
        rgba = np.concatenate([np.clip(np.rint(rgb), 0, 255), np.full((len(rgb), 1), 255.0)], 1)
        return ColouredMesh(
            xyz, faces, "vertex", corner_rgba=rgba.astype(np.uint8)[faces], source=str(path)
        )
    if coloured:
        fallback = _fallback_factor(options)
        colours = np.array(
            [encode_uint8(entries[n].factor if n in entries else fallback) for n in used],
            np.uint8,
        )
        lookup = {name: i for i, name in enumerate(used)}
        face_index = np.array([lookup[n] for n in names.tolist()], dtype=np.int64)
        return ColouredMesh(xyz, faces, "face", face_rgba=colours[face_index], source=str(path))
    return ColouredMesh(xyz, faces, "none", source=str(path))


def _statement(raw: str) -> tuple[str, str]:
    """Split an OBJ/MTL line into its keyword and the rest (spaces or tabs between)."""
    parts = raw.strip().split(None, 1)
    if not parts or parts[0].startswith("#"):
        return "", ""
    return parts[0], parts[1].strip() if len(parts) > 1 else ""


def _warn_texture_unused(path: Path, texture: Path, reason: str) -> None:
    warnings.warn(
        f"{path}: --texture {texture} is not used: {reason}",
        ShellvoxWarning,
        stacklevel=4,
    )


def _warn_undefined(
    path: Path,
    entries: dict[str, _MtlEntry],
    used: list[str],
    names: NDArray[np.object_],
    options: LoadOptions,
) -> None:
    """Warn about ``usemtl`` names that no MTL defines (their faces stay white)."""
    if not entries:
        return
    missing = [n for n in used if n and n not in entries]
    if missing:
        count = int(np.isin(names, missing).sum())
        fallback = "white" if options.colour is None else "the --colour"
        warnings.warn(
            f"{path}: material(s) {', '.join(map(repr, missing))} used by {count} faces are "
            f"not defined in its MTL; those faces are {fallback}",
            ShellvoxWarning,
            stacklevel=3,
        )


def _parse_rows(path: Path, rows: list[str], key: str, needed: int) -> NDArray[np.float64]:
    """Parse whitespace-separated numeric rows into a 2-D array (ragged rows are cut)."""
    width = min(len(row.split()) for row in rows)
    if width < needed:
        raise InputError(
            path, f"has a '{key}' line with fewer than {needed} numbers", "re-export it"
        )
    try:
        flat = np.array(" ".join(" ".join(r.split()[:width]) for r in rows).split(), float)
    except ValueError as error:
        raise InputError(path, f"has a malformed '{key}' line ({error})", "re-export it") from None
    return flat.reshape(len(rows), width)


def _triangulate(
    path: Path, face_lines: list[list[str]], n_positions: int, n_uvs: int
) -> tuple[NDArray[np.int64], NDArray[np.int64] | None, NDArray[np.int64]]:
    """Fan-triangulate OBJ faces; return position and UV indices per corner and owner rows."""
    counts = np.fromiter((len(f) for f in face_lines), dtype=np.int64, count=len(face_lines))
    if counts.min() < 3:
        raise InputError(path, "has a face with fewer than 3 corners", "re-export the mesh")
    tokens = [token for face in face_lines for token in face]
    pos, uv = _corner_indices(path, tokens)
    pos = np.where(pos < 0, pos + n_positions, pos - 1)  # OBJ indices are 1-based or negative
    if uv is not None:
        uv = np.where(uv < 0, uv + n_uvs, uv - 1)
        if uv.min() < 0 or uv.max() >= n_uvs:
            raise InputError(path, "has a face with a 'vt' index out of range", "re-export it")
    if pos.min() < 0 or pos.max() >= n_positions:
        raise InputError(path, "has a face with a vertex index out of range", "re-export it")
    # Fan triangulation (0, i, i + 1) of each polygon, gathered without a loop over faces.
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tris = counts - 2
    owner = np.repeat(np.arange(len(counts)), n_tris)
    local = np.arange(int(n_tris.sum())) - np.repeat(np.cumsum(n_tris) - n_tris, n_tris)
    corner = np.stack([starts[owner], starts[owner] + local + 1, starts[owner] + local + 2], axis=1)
    return pos[corner], None if uv is None else uv[corner], owner


def _corner_indices(
    path: Path, tokens: list[str]
) -> tuple[NDArray[np.int64], NDArray[np.int64] | None]:
    """Position and UV indices of face corners written ``v``, ``v/vt``, ``v/vt/vn``, ``v//vn``."""
    joined = " ".join(tokens)
    first = tokens[0]
    slashes = first.count("/")
    uniform = joined.count("/") == slashes * len(tokens) and joined.count("//") in (
        0,
        len(tokens) if "//" in first else -1,
    )
    try:
        per_corner = slashes + 1 - ("//" in first)
        if uniform:  # the usual case: parse all corners at once
            fields = np.array(joined.replace("//", "/").replace("/", " ").split(), np.int64)
            if fields.size == per_corner * len(tokens):
                table = fields.reshape(len(tokens), per_corner)
                has_uv = slashes >= 1 and "//" not in first
                return table[:, 0], table[:, 1] if has_uv else None
        parts = [token.split("/") for token in tokens]
        pos = np.array([int(p[0]) for p in parts], dtype=np.int64)
        uv_ok = all(len(p) > 1 and p[1] != "" for p in parts)
        uv = np.array([int(p[1]) for p in parts], dtype=np.int64) if uv_ok else None
    except ValueError:
        raise InputError(path, "has a malformed 'f' line", "re-export the mesh") from None
    return pos, uv


def _resolve(
    model: Path, base: Path, name: str, what: str, *, force: bool, alternative: str = ""
) -> Path | None:
    """Find a file named in an OBJ/MTL, under the path policy; None when it is missing.

    Spaces, tabs, quotes, backslashes and letter case are forgiven; a name pointing out
    of the OBJ's folder is looked for by its file name in ``base`` first.
    """
    cleaned = name.strip().strip('"').replace("\\", "/")
    declared = base / cleaned
    if declared.is_file() and is_inside(model.parent, declared):
        return declared
    local = base / Path(cleaned).name
    if local.is_file() and is_inside(model.parent, local):
        return local
    wanted = Path(cleaned).name.lower()
    if base.is_dir():
        for entry in sorted(base.iterdir()):
            if entry.name.lower() == wanted and entry.is_file() and is_inside(model.parent, entry):
                return entry
    if declared.is_file():  # only the file outside the folder exists
        return check_inside(model, declared, what, force=force, alternative=alternative)
    return None


def _read_materials(path: Path, mtllibs: list[str], options: LoadOptions) -> dict[str, _MtlEntry]:
    """Read the MTL libraries an OBJ names; apply the missing-MTL rules."""
    found: list[Path] = []
    missing: list[str] = []
    for name in mtllibs:
        what = f"material library {name!r}"
        mtl = _resolve(path, path.parent, name, what, force=options.force)
        if mtl is None and len(name.split()) > 1:  # "mtllib a.mtl b.mtl"
            parts = [
                _resolve(path, path.parent, n, what, force=options.force) for n in name.split()
            ]
            if all(p is not None for p in parts):
                found += [p for p in parts if p is not None]
                continue
        if mtl is None:
            missing.append(name)
        else:
            found.append(mtl)
    if missing and found:
        warnings.warn(
            f"{path}: material library {missing[0]!r} is missing; the materials of "
            f"{', '.join(repr(f.name) for f in found)} are used",
            ShellvoxWarning,
            stacklevel=3,
        )
    elif missing:
        if options.texture is not None or options.colour is not None:
            warnings.warn(
                f"{path}: MTL file {missing[0]!r} not found; using the "
                "--texture/--colour given instead",
                ShellvoxWarning,
                stacklevel=3,
            )
            return {}
        raise InputError(
            path,
            f"its material library {missing[0]!r} is missing",
            "put the MTL beside the OBJ, or pass --texture FILE or --colour R,G,B",
        )
    entries: dict[str, _MtlEntry] = {}
    for mtl in found:
        entries.update(_parse_mtl(mtl))
    return entries


def _parse_mtl(mtl: Path) -> dict[str, _MtlEntry]:
    """Parse one MTL file's ``newmtl`` blocks (``Kd``, ``d``/``Tr``, ``map_Kd``)."""
    blocks: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    for raw in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
        key, rest = _statement(raw)
        if key == "newmtl":
            current = blocks.setdefault(rest, {})
        elif key and current is not None:
            current[key.lower()] = rest
    entries: dict[str, _MtlEntry] = {}
    for name, block in blocks.items():
        alpha = 1.0
        if "d" in block:
            alpha = _number(mtl, name, "d", block["d"])
        elif "tr" in block:
            alpha = 1.0 - _number(mtl, name, "Tr", block["tr"])
        kd = _kd(mtl, name, block.get("kd", "1 1 1"))
        texture, wrap = _map_statement(mtl, name, block.get("map_kd"))
        factor = np.append(srgb_to_linear(np.clip(kd, 0.0, 1.0)), np.clip(alpha, 0.0, 1.0))
        entries[name] = _MtlEntry(name, mtl, factor, texture, wrap)
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
        warnings.warn(
            f"{mtl}: material {material!r} gives its Kd as '{tokens[0]}', which shellvox "
            "does not read; its faces are white",
            ShellvoxWarning,
            stacklevel=4,
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
            warnings.warn(
                f"{mtl}: material {material!r}: map_Kd option {option} "
                f"{' '.join(arguments)} is not applied (the texture is used unshifted and "
                "unscaled); bake it into the UVs to keep it",
                ShellvoxWarning,
                stacklevel=4,
            )
    return rest.strip() or None, wrap


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _fallback_factor(options: LoadOptions) -> NDArray[np.float64]:
    """Linear RGBA of ``--colour``, or white, for faces without a usable material."""
    if options.colour is None:
        return np.ones(4)
    values = np.asarray(options.colour, dtype=np.float64) / 255.0
    return np.append(srgb_to_linear(values[:3]), values[3])


def _texture_materials(
    path: Path,
    entries: dict[str, _MtlEntry],
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
        refs.append(TextureRef(path, f"--texture {options.texture}", options.texture))
        images = read_textures(refs, colour=options.colour, force=options.force)
        image = images[0]
        if image is None:
            return {"": Material("texture", factor=_fallback_factor(options))}, True
        return {"": Material("texture", image=image)}, True
    for name in textured:
        entry = entries[name]
        assert entry.texture is not None
        what = f"texture {entry.texture!r} of material {name!r}"
        source = _resolve(
            path,
            entry.mtl.parent,
            entry.texture,
            what,
            force=options.force,
            alternative="pass --texture FILE",
        )
        if source is None and options.texture is not None:
            source = options.texture
        refs.append(TextureRef(entry.mtl, what, source, TEXTURE_FIX))
    images = read_textures(refs, colour=options.colour, force=options.force)
    table: dict[str, Material] = {}
    for name, image in zip(textured, images, strict=True):
        if image is None:
            table[name] = Material(name, factor=_fallback_factor(options))
        else:
            table[name] = Material(name, image=image, wrap=entries[name].wrap)
    for name in used:
        if name not in table:
            factor = entries[name].factor if name in entries else _fallback_factor(options)
            table[name] = Material(name or "default", factor=factor)
    return table, any(ref.source is options.texture for ref in refs)
