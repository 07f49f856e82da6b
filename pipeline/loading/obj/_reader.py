"""Wavefront OBJ + MTL reader: positions, per-corner UVs, materials, vertex colours.

Written here rather than taken from trimesh so that per-face materials stay distinct, MTL
texture paths with spaces, tabs or Windows backslashes resolve, and a missing MTL or
texture is an error (or, if the user asked, a warning and a fallback) instead of silent
grey. Statements may be separated by spaces or tabs (MeshLab writes
``newmtl<TAB>name<TAB><TAB>`` and ``map_Kd<TAB>file with spaces.png``).

Referenced files (``mtllib``, ``map_Kd``) follow the path policy of
:mod:`shellvox.loading._references`: they must lie in the OBJ's folder or below it. A name
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

from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, opt, warn
from shellvox.loading.obj._mtl import MtlEntry, fallback_factor, read_materials, texture_materials
from shellvox.model import ColouredMesh
from shellvox.voxel.colour import encode_uint8


class _Statements(NamedTuple):
    """The statements of an OBJ file that shellvox reads, as text."""

    positions: list[str]  # the rest of each ``v`` line
    uvs: list[str]  # of each ``vt`` line
    face_lines: list[list[str]]  # the corners of each ``f`` line
    face_material_names: list[str]  # the ``usemtl`` name in force at each ``f`` line
    mtllibs: list[str]


class _Geometry(NamedTuple):
    """Triangulated geometry of an OBJ file, in file units."""

    xyz: NDArray[np.float64]  # (V, 3)
    faces: NDArray[np.int64]  # (F, 3) position indices
    vertex_rgb: NDArray[np.float64] | None  # (V, 3) ``v x y z r g b``, 0..1 or 0..255
    uv_rows: NDArray[np.float64]  # (T, 2)
    uv_index: NDArray[np.int64] | None  # (F, 3) indices into uv_rows, None without ``vt``
    names: NDArray[np.object_]  # (F,) each face's material name
    used: list[str]  # the material names used, sorted


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
    statements = _statements(path)
    geometry = _geometry(path, statements)
    entries = read_materials(path, statements.mtllibs, options)
    _warn_undefined(path, entries, geometry.used, geometry.names, options)
    textured = _textured(path, entries, geometry, options)
    if textured or (options.texture is not None and not entries):
        return _textured_mesh(path, entries, textured, geometry, options)
    if options.texture is not None:  # has_uv, an MTL, but no map_Kd on the faces
        _warn_texture_unused(path, options.texture, "the MTL gives its faces no map_Kd")
    return _untextured_mesh(path, entries, geometry, options)


def _statements(path: Path) -> _Statements:
    """Read the ``v``, ``vt``, ``f``, ``usemtl`` and ``mtllib`` statements of the file."""
    # Tabs separate statements as well as spaces do (MeshLab): one replace over the text
    # keeps the per-line work to a partition.
    text = path.read_text(encoding="utf-8", errors="replace").replace("\t", " ")
    found = _Statements([], [], [], [], [])
    material = ""
    for raw in text.splitlines():
        key, _, rest = raw.strip().partition(" ")
        if key == "v":
            found.positions.append(rest)
        elif key == "vt":
            found.uvs.append(rest)
        elif key == "f":
            found.face_lines.append(rest.split())
            found.face_material_names.append(material)
        elif key == "usemtl":
            material = rest.strip()
        elif key == "mtllib":
            found.mtllibs.append(rest.strip())
    if not found.positions or not found.face_lines:
        raise InputError(path, "has no vertices or no faces", "export the mesh with its faces")
    return found


def _geometry(path: Path, statements: _Statements) -> _Geometry:
    """Parse the vertices and texture coordinates and triangulate the faces."""
    vertex_rows = _parse_rows(path, statements.positions, "v", 3)
    xyz = vertex_rows[:, :3]
    vertex_rgb = vertex_rows[:, 3:6] if vertex_rows.shape[1] >= 6 else None
    uvs = statements.uvs
    uv_rows = _parse_rows(path, uvs, "vt", 1) if uvs else np.zeros((0, 2))
    if uv_rows.shape[1] == 1:  # "vt u": v defaults to 0
        uv_rows = np.concatenate([uv_rows, np.zeros_like(uv_rows)], axis=1)
    uv_rows = uv_rows[:, :2]
    faces, uv_index, owner = _triangulate(path, statements.face_lines, len(xyz), len(uv_rows))
    names = np.asarray(statements.face_material_names, dtype=object)[owner]
    used = sorted(set(names.tolist()))
    return _Geometry(xyz, faces, vertex_rgb, uv_rows, uv_index, names, used)


def _textured(
    path: Path, entries: dict[str, MtlEntry], geometry: _Geometry, options: LoadOptions
) -> list[str]:
    """Return the used materials whose texture colours the faces (none without ``vt``)."""
    uv_index = geometry.uv_index
    has_uv = uv_index is not None and bool((uv_index >= 0).all())
    textured = [n for n in geometry.used if n in entries and entries[n].texture is not None]
    if has_uv:
        return textured
    if options.texture is not None:
        raise InputError(
            path,
            f"has no texture coordinates ('vt' on every face), so {opt('texture')} cannot be "
            "applied",
            f"export the OBJ with UVs, or pass {opt('colour')} instead of {opt('texture')}",
        )
    if textured:
        warn(
            f"{path}: material(s) {', '.join(map(repr, textured))} have a texture but "
            "not every face has texture coordinates ('vt'); their Kd colour is used",
        )
    return []


def _textured_mesh(
    path: Path,
    entries: dict[str, MtlEntry],
    textured: list[str],
    geometry: _Geometry,
    options: LoadOptions,
) -> ColouredMesh:
    """Return the mesh coloured by its materials' textures (or, all replaced, their factors)."""
    xyz, faces, names, used = geometry.xyz, geometry.faces, geometry.names, geometry.used
    assert geometry.uv_index is not None
    table, texture_used = texture_materials(path, entries, textured, used, options)
    if options.texture is not None and not texture_used:
        _warn_texture_unused(path, options.texture, "the MTL's textures were all found")
    if geometry.vertex_rgb is not None:
        warn(
            f"{path}: its vertex colours ('v x y z r g b') are ignored: "
            "the materials' textures colour the faces",
        )
    if not entries:
        names = np.full(len(faces), "", dtype=object)
        used = [""]
    lookup = {name: i for i, name in enumerate(used)}
    face_material = np.array([lookup[n] for n in names.tolist()], dtype=np.int64)
    if all(table[name].image is None for name in used):  # every texture replaced
        colours = np.array([encode_uint8(table[name].factor) for name in used], np.uint8)
        return ColouredMesh(xyz, faces, "face", face_rgba=colours[face_material], source=str(path))
    return ColouredMesh(
        xyz,
        faces,
        "texture",
        corner_uv=geometry.uv_rows[geometry.uv_index],
        face_material=face_material,
        materials=tuple(table[name] for name in used),
        source=str(path),
    )


def _untextured_mesh(
    path: Path, entries: dict[str, MtlEntry], geometry: _Geometry, options: LoadOptions
) -> ColouredMesh:
    """Return the mesh coloured by its vertex colours, else its materials' ``Kd``, or none."""
    xyz, faces, used = geometry.xyz, geometry.faces, geometry.used
    coloured = [n for n in used if n in entries]
    if geometry.vertex_rgb is not None:
        if coloured:
            warn(
                f"{path}: the Kd colours of material(s) {', '.join(map(repr, coloured))} "
                "are ignored: its vertex colours ('v x y z r g b') colour the faces",
            )
        vertex_rgb = geometry.vertex_rgb
        rgb = vertex_rgb if vertex_rgb.max() > 1.0 + 1e-9 else vertex_rgb * 255.0
        rgba = np.concatenate([np.clip(np.rint(rgb), 0, 255), np.full((len(rgb), 1), 255.0)], 1)
        return ColouredMesh(
            xyz, faces, "vertex", corner_rgba=rgba.astype(np.uint8)[faces], source=str(path)
        )
    if coloured:
        fallback = fallback_factor(options)
        colours = np.array(
            [encode_uint8(entries[n].factor if n in entries else fallback) for n in used],
            np.uint8,
        )
        lookup = {name: i for i, name in enumerate(used)}
        face_index = np.array([lookup[n] for n in geometry.names.tolist()], dtype=np.int64)
        return ColouredMesh(xyz, faces, "face", face_rgba=colours[face_index], source=str(path))
    return ColouredMesh(xyz, faces, "none", source=str(path))


def _warn_texture_unused(path: Path, texture: Path, reason: str) -> None:
    warn(
        f"{path}: {opt('texture', str(texture))} is not used: {reason}",
    )


def _warn_undefined(
    path: Path,
    entries: dict[str, MtlEntry],
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
        fallback = "white" if options.colour is None else f"the {opt('colour')}"
        warn(
            f"{path}: material(s) {', '.join(map(repr, missing))} used by {count} faces are "
            f"not defined in its MTL; those faces are {fallback}",
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
    except OverflowError:  # beyond int64: no file has that many vertices
        raise InputError(
            path, "has a face with an index out of range (beyond 64 bits)", "re-export it"
        ) from None
    except ValueError:
        raise InputError(path, "has a malformed 'f' line", "re-export the mesh") from None
    return pos, uv
