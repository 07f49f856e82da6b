"""Wavefront OBJ + MTL reader: positions, per-corner UVs, materials, vertex colours.

Written here rather than taken from trimesh so that per-face materials stay distinct, MTL
texture paths with spaces or Windows backslashes resolve, and a missing MTL or texture
is an error (or, if the user asked, a warning and a fallback) instead of silent grey.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.config import LoadOptions
from pipeline.errors import InputError, ShellvoxWarning
from pipeline.loading.images import read_texture
from pipeline.mesh import ColouredMesh
from pipeline.texture import Material, encode_uint8, srgb_to_linear


def read_obj(path: Path, options: LoadOptions) -> ColouredMesh:
    """Read an OBJ file (and its MTL and textures) into an unmerged mesh.

    Parameters
    ----------
    path : Path
        The ``.obj`` file.
    options : LoadOptions
        ``texture`` replaces a missing MTL or ``map_Kd``; ``colour`` is the fallback
        colour for a missing texture (with a warning).

    Returns
    -------
    ColouredMesh
        In file units, vertices not yet merged by position.
    """
    text = path.read_text(encoding="utf-8", errors="replace")
    positions: list[str] = []
    uvs: list[str] = []
    face_lines: list[list[str]] = []
    face_material_names: list[str] = []
    mtllibs: list[str] = []
    material = ""
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line[0] == "#":
            continue
        key, _, rest = line.partition(" ")
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

    vertex_rows = _parse_rows(path, positions, "v")
    xyz = vertex_rows[:, :3]
    vertex_rgb = vertex_rows[:, 3:6] if vertex_rows.shape[1] >= 6 else None
    uv_rows = _parse_rows(path, uvs, "vt")[:, :2] if uvs else np.zeros((0, 2))
    pos_index, uv_index, triangle_owner = _triangulate(path, face_lines, len(xyz), len(uv_rows))
    faces = pos_index
    names = np.asarray(face_material_names, dtype=object)[triangle_owner]

    materials = _read_materials(path, mtllibs, set(face_material_names) - {""}, options)
    textured = {name for name, mat in materials.items() if mat.image is not None}
    used = sorted(set(names.tolist()))
    has_uv = uv_index is not None and bool((uv_index >= 0).all())

    if has_uv and (textured & set(used) or (options.texture is not None and not materials)):
        assert uv_index is not None
        if not materials and options.texture is not None:
            materials = {"": Material("texture", image=read_texture(options.texture, path))}
            used = [""]
            names = np.full(len(faces), "", dtype=object)
        table = [materials.get(name, Material(name or "default")) for name in used]
        lookup = {name: i for i, name in enumerate(used)}
        face_material = np.array([lookup[n] for n in names.tolist()], dtype=np.int64)
        return ColouredMesh(
            xyz,
            faces,
            "texture",
            corner_uv=uv_rows[uv_index],
            face_material=face_material,
            materials=tuple(table),
            source=str(path),
        )
    if vertex_rgb is not None:
        rgb = vertex_rgb if vertex_rgb.max() > 1.0 + 1e-9 else vertex_rgb * 255.0
        rgba = np.concatenate([np.clip(np.rint(rgb), 0, 255), np.full((len(rgb), 1), 255.0)], 1)
        return ColouredMesh(
            xyz, faces, "vertex", corner_rgba=rgba.astype(np.uint8)[faces], source=str(path)
        )
    if materials and used != [""]:
        colours = np.array([_material_rgba(materials.get(name)) for name in used], np.uint8)
        lookup = {name: i for i, name in enumerate(used)}
        face_index = np.array([lookup[n] for n in names.tolist()], dtype=np.int64)
        return ColouredMesh(xyz, faces, "face", face_rgba=colours[face_index], source=str(path))
    return ColouredMesh(xyz, faces, "none", source=str(path))


def _parse_rows(path: Path, rows: list[str], key: str) -> NDArray[np.float64]:
    """Parse whitespace-separated numeric rows into a 2-D array (ragged rows are cut)."""
    width = min(len(row.split()) for row in rows)
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


def _resolve(base: Path, name: str) -> Path | None:
    """Find a file named in an OBJ/MTL: spaces, backslashes, case and folders forgiven."""
    cleaned = name.strip().strip('"').replace("\\", "/")
    candidates = [base / cleaned, base / Path(cleaned).name]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    wanted = Path(cleaned).name.lower()
    if base.is_dir():
        for entry in base.iterdir():
            if entry.name.lower() == wanted and entry.is_file():
                return entry
    return None


def _read_materials(
    path: Path, mtllibs: list[str], wanted: set[str], options: LoadOptions
) -> dict[str, Material]:
    """Read the MTL libraries an OBJ names; apply the missing-MTL/texture rules."""
    if not mtllibs:
        return {}
    found = [_resolve(path.parent, name) for name in mtllibs]
    if any(f is None for f in found) and not all(f is None for f in found):
        found = [f for f in found if f is not None]
    if all(f is None for f in found):
        if options.texture is not None or options.colour is not None:
            warnings.warn(
                f"{path}: MTL file {mtllibs[0]!r} not found; using the "
                "--texture/--colour given instead",
                ShellvoxWarning,
                stacklevel=2,
            )
            return {}
        raise InputError(
            path,
            f"its material library {mtllibs[0]!r} is missing",
            "put the MTL beside the OBJ, or pass --texture FILE or --colour R,G,B",
        )
    materials: dict[str, Material] = {}
    for mtl in found:
        assert mtl is not None
        materials.update(_parse_mtl(path, mtl, options))
    return materials


def _parse_mtl(obj_path: Path, mtl: Path, options: LoadOptions) -> dict[str, Material]:
    entries: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    for raw in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        key, _, rest = line.partition(" ")
        if key == "newmtl":
            current = entries.setdefault(rest.strip(), {})
        elif current is not None:
            current[key.lower()] = rest.strip()
    materials: dict[str, Material] = {}
    for name, entry in entries.items():
        alpha = float(entry["d"].split()[0]) if "d" in entry else 1.0
        if "tr" in entry and "d" not in entry:
            alpha = 1.0 - float(entry["tr"].split()[0])
        kd = [float(x) for x in entry.get("kd", "1 1 1").split()[:3]]
        texture = _map_filename(entry.get("map_kd"))
        if texture is None:
            factor = np.append(srgb_to_linear(np.array(kd)), alpha)
            materials[name] = Material(name, factor=factor)
            continue
        image_path = _resolve(mtl.parent, texture)
        if image_path is None and options.texture is not None:
            image_path = options.texture
        if image_path is None:
            if options.colour is not None:
                warnings.warn(
                    f"{mtl}: texture {texture!r} not found; using --colour "
                    f"{options.colour} instead",
                    ShellvoxWarning,
                    stacklevel=2,
                )
                materials[name] = Material(name, factor=_rgba_to_factor(options.colour))
                continue
            raise InputError(
                mtl,
                f"texture {texture!r} of material {name!r} is missing",
                "put the image beside the MTL, or pass --texture FILE or --colour R,G,B",
            )
        materials[name] = Material(name, image=read_texture(image_path, obj_path))
    return materials


def _map_filename(value: str | None) -> str | None:
    """Strip ``map_Kd`` options (``-s 1 1 1``, ``-clamp on``...) and return the file name."""
    if value is None:
        return None
    tokens = value.split()
    arity = {
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
    i = 0
    while i < len(tokens) and tokens[i].lower() in arity:
        i += 1 + arity[tokens[i].lower()]
    name = " ".join(tokens[i:])
    return name or None


def _rgba_to_factor(rgba: tuple[int, int, int, int]) -> NDArray[np.float64]:
    values = np.asarray(rgba, dtype=np.float64) / 255.0
    return np.append(srgb_to_linear(values[:3]), values[3])


def _material_rgba(material: Material | None) -> NDArray[np.uint8]:
    if material is None:
        return np.array([255, 255, 255, 255], dtype=np.uint8)
    rgba: NDArray[np.uint8] = encode_uint8(material.factor[None])[0]
    return rgba
