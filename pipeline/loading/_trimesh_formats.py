"""PLY, STL and OFF through trimesh, with colour taken over faithfully.

trimesh parses the geometry; this module turns its visuals into shellvox's colour
sources: textures with per-corner UVs (a PLY ``comment TextureFile``, read here under
the path policy and pixel budget of :mod:`shellvox.loading._references` and
:mod:`shellvox.loading._images`, not by trimesh), vertex colours, face colours, or none.
A PLY colour that cannot be used (a ``TextureFile`` without texture coordinates, colour
properties other than ``red green blue [alpha]``) gives a one-line warning. An STL is
checked to be binary or ASCII STL before trimesh sees it; the parts are joined by
:func:`shellvox.loading._combine.combine_parts`.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, warn
from shellvox.loading._combine import checked_faces, combine_parts
from shellvox.loading._images import TextureRef, read_textures
from shellvox.loading._references import check_inside, is_file
from shellvox.model import ColouredMesh, Material

#: PLY properties that look like colour but are not the ``red green blue`` trimesh reads.
PLY_COLOURISH = {
    "r",
    "g",
    "b",
    "diffuse_red",
    "diffuse_green",
    "diffuse_blue",
    "color",
    "colour",
    "rgb",
    "rgba",
}


def read_with_trimesh(path: Path, file_type: str, options: LoadOptions) -> ColouredMesh:
    """Read a PLY, STL or OFF file into an unmerged mesh in file units."""
    texture: NDArray[np.uint8] | None = None
    texture_name = None
    if file_type == "stl":
        _check_stl(path)
    if file_type == "ply":
        texture_name, texture = _ply_header(path, options)
    loaded = load_with_trimesh(path, file_type, skip_materials=file_type == "ply")
    if isinstance(loaded, trimesh.Scene):
        parts = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
    elif isinstance(loaded, trimesh.Trimesh):
        parts = [loaded]
    else:
        parts = []
    parts = [p for p in parts if len(p.faces)]
    if not parts:
        raise InputError(path, "contains no triangles", "export the mesh with its faces")
    return combine_parts(path, [_part(path, p, texture_name, texture, options) for p in parts])


def load_with_trimesh(path: Path, file_type: str, **kwargs: Any) -> Any:
    """``trimesh.load`` without processing; any failure is an :class:`InputError`."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return trimesh.load(
                str(path), file_type=file_type, process=False, maintain_order=True, **kwargs
            )
    except Exception as error:  # trimesh raises many types for malformed files
        raise InputError(
            path,
            f"could not be parsed as {file_type.upper()} ({type(error).__name__}: {error})",
            "check the file or re-export it",
        ) from None


def _check_stl(path: Path) -> None:
    """Refuse a file that is neither binary STL (exact size) nor ASCII STL."""
    size = path.stat().st_size
    with path.open("rb") as handle:
        head = handle.read(1024)
    if size >= 84:
        count = int.from_bytes(head[80:84], "little")
        if size == 84 + 50 * count:
            return
    text = head.lstrip().lower()
    if text.startswith(b"solid") and (b"facet" in text or size <= 1024) and _is_text(head):
        return
    expected = ""
    if size >= 84:
        count = int.from_bytes(head[80:84], "little")
        expected = f" (a binary STL of {count:,} triangles would be {84 + 50 * count:,} bytes)"
    raise InputError(
        path,
        f"is not a valid STL: neither ASCII STL ('solid ... facet') nor binary STL of "
        f"{size:,} bytes{expected}",
        "export the model again as STL",
    )


def _is_text(data: bytes) -> bool:
    return b"\0" not in data and all(32 <= c < 127 or c in b"\t\r\n" for c in data[:1024])


def _ply_header(path: Path, options: LoadOptions) -> tuple[str | None, NDArray[np.uint8] | None]:
    """Warn about colour properties trimesh does not read; read the TextureFile, if any."""
    with path.open("rb") as handle:
        head = handle.read(65536)
    end = head.find(b"end_header")
    header = head[: end if end >= 0 else len(head)].decode("latin-1")
    properties: dict[str, set[str]] = {}
    element = ""
    texture_name = None
    for line in header.splitlines():
        words = line.split()
        if words[:1] == ["element"] and len(words) > 1:
            element = words[1]
            properties[element] = set()
        elif words[:1] == ["property"] and element:
            properties[element].add(words[-1])
        elif words[:1] == ["comment"] and "texturefile" in line.lower():
            texture_name = line[line.lower().index("texturefile") + 11 :].strip()
    for element, names in properties.items():
        odd = sorted(names & PLY_COLOURISH)
        if odd and not {"red", "green", "blue"} <= names:
            warn(
                f"{path}: {element} properties {', '.join(odd)} are not read as colour "
                "(shellvox reads red, green, blue and alpha)",
            )
    if texture_name is None:
        return None, None
    vertex = properties.get("vertex", set())
    face = properties.get("face", set())
    if not (
        {"u", "v"} <= vertex
        or {"s", "t"} <= vertex
        or {"texture_u", "texture_v"} <= vertex
        or "texcoord" in face
    ):
        warn(
            f"{path}: TextureFile {texture_name!r} is ignored: the PLY has no texture coordinates",
        )
        return None, None
    what = f"TextureFile {texture_name!r}"
    candidate = path.parent / texture_name
    source = (
        check_inside(path, candidate, what, force=options.force) if is_file(candidate) else None
    )
    ref = TextureRef(path, what, source, "put the image beside the PLY")
    return texture_name, read_textures([ref], colour=options.colour, force=options.force)[0]


def _part(
    path: Path,
    mesh: trimesh.Trimesh,
    texture_name: str | None,
    texture: NDArray[np.uint8] | None,
    options: LoadOptions,
) -> dict[str, Any]:
    faces = checked_faces(path, len(mesh.vertices), np.asarray(mesh.faces, dtype=np.int64))
    part: dict[str, Any] = {"vertices": np.asarray(mesh.vertices, np.float64), "faces": faces}
    visual: Any = mesh.visual
    kind = getattr(visual, "kind", None)
    has_uv = kind == "texture" and visual.uv is not None and len(visual.uv) == len(mesh.vertices)
    if texture_name is not None and has_uv:
        if texture is None:  # replaced by --colour; read_textures warned
            assert options.colour is not None
            part["rgba"] = np.broadcast_to(np.asarray(options.colour, np.uint8), (*faces.shape, 4))
            return part
        part["material"] = Material(texture_name, image=texture)
        part["uv"] = np.asarray(visual.uv, np.float64)[faces]
        return part
    if kind == "vertex":
        part["rgba"] = np.asarray(visual.vertex_colors, dtype=np.uint8)[faces]
    elif kind == "face":
        part["rgba"] = np.repeat(np.asarray(visual.face_colors, np.uint8)[:, None], 3, axis=1)
    return part
