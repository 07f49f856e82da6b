"""Slicer projects saved as 3MF: filament colours, each volume's extruder, painted faces.

PrusaSlicer writes ``Metadata/Slic3r_PE.config`` (``; extruder_colour = ...`` and
``; filament_colour = ...``, ``;``-separated; an empty extruder colour falls back to the
filament colour, as in PrusaSlicer's preview) and ``Metadata/Slic3r_PE_model.config``
(per object: ``extruder``; per volume: triangle range ``firstid..lastid``, ``extruder``,
``volume_type``). Bambu Studio and OrcaSlicer write ``Metadata/project_settings.config``
(JSON, ``filament_colour``) and ``Metadata/model_settings.config`` (per object id of the
root model: ``extruder``; per ``<part id=...>``, the component's object id: ``subtype``
and ``extruder``). An unpainted face prints with its volume's extruder, else its
object's, else extruder 1; extruder 0 means "the object's".

Volumes that are not model parts (modifiers, negative volumes, support blockers and
enforcers) are not geometry: their faces are left out, with a warning.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError, warn
from shellvox.loading.threemf._package import read_entry
from shellvox.loading.threemf._paint_tree import split_painted

PRUSA_CONFIG = "Metadata/Slic3r_PE.config"
PRUSA_MODEL = "Metadata/Slic3r_PE_model.config"
BAMBU_CONFIG = "Metadata/project_settings.config"
BAMBU_MODEL = "Metadata/model_settings.config"
PRUSA_NS = "{http://schemas.slic3r.org/3mf/2017/06}"
#: Triangle attributes holding paint: PrusaSlicer's, then Bambu Studio's and OrcaSlicer's.
PAINT_ATTRIBUTES = (f"{PRUSA_NS}mmu_segmentation", "paint_color")
MODEL_PARTS = ("ModelPart", "normal_part")
#: Extruder colours when a painted file names none (sRGB): told in a warning.
PALETTE = np.array(
    [[255, 255, 255], [220, 40, 40], [40, 160, 60], [40, 80, 220], [240, 200, 40],
     [30, 30, 30], [230, 110, 30], [150, 60, 180]],
    dtype=np.uint8,
)  # fmt: skip


@dataclass
class SlicerProject:
    """What a slicer project says about colour.

    Parameters
    ----------
    colours : (E, 4) uint8
        sRGB + alpha of extruders (filaments) 1..E; empty when the project names none.
    object_extruder : dict of str to int
        Extruder of each configured object (by the object id the config uses).
    volumes : dict of str to list of (first, last, extruder, is_part)
        PrusaSlicer: each object's volumes as triangle ranges.
    parts : dict of (str, str) to (extruder, is_part)
        Bambu Studio / OrcaSlicer: each (object id, part object id).
    """

    colours: NDArray[np.uint8]
    object_extruder: dict[str, int] = field(default_factory=dict)
    volumes: dict[str, list[tuple[int, int, int, bool]]] = field(default_factory=dict)
    parts: dict[tuple[str, str], tuple[int, bool]] = field(default_factory=dict)

    def face_extruders(
        self, trail: tuple[str, ...], n_faces: int
    ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Extruder of each face of one object's mesh, and which faces are model parts.

        Parameters
        ----------
        trail : tuple of str
            Object ids from the build item's object down to the mesh object.
        n_faces : int
            Faces of the mesh.

        Returns
        -------
        extruder : (F,) int64
            1-based extruder of unpainted faces.
        keep : (F,) bool
            False for faces of volumes that are not model parts.
        """
        extruder = np.zeros(n_faces, dtype=np.int64)
        keep = np.ones(n_faces, dtype=bool)
        for first, last, volume_extruder, is_part in self.volumes.get(trail[-1], []):
            extruder[first : last + 1] = volume_extruder
            keep[first : last + 1] = is_part
        part_extruder, is_part = self.parts.get((trail[0], trail[-1]), (0, True))
        extruder[extruder == 0] = part_extruder
        keep &= is_part
        default = self.object_extruder.get(trail[0], 0) or self.object_extruder.get(trail[-1], 0)
        extruder[extruder == 0] = default or 1
        return extruder, keep


def read_project(path: Path, archive: zipfile.ZipFile) -> SlicerProject | None:
    """Read the slicer's project files from the package, or None if it has none."""
    names = set(archive.namelist())
    if PRUSA_CONFIG in names or PRUSA_MODEL in names:
        colours = _none()
        if PRUSA_CONFIG in names:
            text = read_entry(path, archive, PRUSA_CONFIG).decode("utf-8", "replace")
            colours = _prusa_colours(text)
        project = SlicerProject(colours)
        if PRUSA_MODEL in names:
            _prusa_model(path, _xml(path, archive, PRUSA_MODEL), project)
        return project
    if BAMBU_CONFIG in names or BAMBU_MODEL in names:
        colours = _none()
        if BAMBU_CONFIG in names:
            try:
                settings = json.loads(read_entry(path, archive, BAMBU_CONFIG))
            except (ValueError, UnicodeDecodeError) as error:
                raise InputError(
                    path, f"{BAMBU_CONFIG} is not JSON ({error})", "re-save it in the slicer"
                ) from None
            listed = settings.get("filament_colour", []) if isinstance(settings, dict) else []
            colours = _colours(path, [str(c) for c in listed])
        project = SlicerProject(colours)
        if BAMBU_MODEL in names:
            _bambu_model(path, _xml(path, archive, BAMBU_MODEL), project)
        return project
    return None


def paint_parts(
    path: Path, parts: list[dict[str, Any]], project: SlicerProject | None
) -> list[dict[str, Any]]:
    """Colour mesh parts by slicer paint and extruder, as the slicer would print them.

    Parameters
    ----------
    path : Path
        The package, for messages.
    parts : list of dict
        Mesh parts of :mod:`shellvox.loading.threemf._reader` (``vertices``, ``faces``, ``rgba``,
        ``uv``, ``material``, ``coloured``, ``paint`` (list of str or None), ``trail``).
    project : SlicerProject or None
        The slicer's project files, if the package has them.

    Returns
    -------
    list of dict
        Painted parts split along the paint (:func:`~shellvox.loading.threemf._paint_tree.
        split_painted`) with per-face colours; parts without paint coloured by their
        extruder when a project is present and the 3MF gives them no colour; the
        faces of volumes that are not model parts left out. Other parts unchanged.
    """
    painted = any(p["paint"] is not None for p in parts)
    if project is None and not painted:
        return parts
    colours = project.colours if project is not None else _none()
    if painted and len(colours) == 0:
        colours = np.concatenate([PALETTE, np.full((len(PALETTE), 1), 255, np.uint8)], axis=1)
        warn(
            f"{path}: is painted in a slicer but names no filament colours; extruders 1-8 "
            "get white, red, green, blue, yellow, black, orange, purple",
        )
    out, dropped, missing = [], 0, set()
    for part in parts:
        if part["paint"] is None and (project is None or part["coloured"].any()):
            out.append(part)  # the 3MF's own colours
            continue
        vertices, faces = part["vertices"], part["faces"]
        extruder, keep = (
            project.face_extruders(part["trail"], len(faces))
            if project is not None
            else (np.ones(len(faces), np.int64), np.ones(len(faces), bool))
        )
        if part["paint"] is not None:
            vertices, faces, state, source = split_painted(path, vertices, faces, part["paint"])
            extruder, keep = np.where(state > 0, state, extruder[source]), keep[source]
        dropped += int((~keep).sum())
        extruder, faces = extruder[keep], faces[keep]
        known = (extruder >= 1) & (extruder <= len(colours))
        missing |= set(extruder[~known].tolist())
        table = np.concatenate([colours, np.full((1, 4), 255, np.uint8)])  # last: white
        rgba = table[np.where(known, extruder - 1, len(colours))]
        n = len(faces)
        out.append(
            {
                "vertices": vertices,
                "faces": faces,
                "rgba": np.repeat(rgba[:, None], 3, axis=1),
                "uv": np.zeros((n, 3, 2)),
                "material": np.full(n, -1, np.int64),
                "coloured": np.ones(n, bool),
            }
        )
    if dropped:
        warn(
            f"{path}: left out {dropped} faces of modifier, negative or support volumes "
            "(they are slicer settings, not geometry)",
        )
    if missing:
        warn(
            f"{path}: extruders {sorted(missing)} have no colour in the project; their "
            "faces are white",
        )
    return [p for p in out if len(p["faces"])]


def _none() -> NDArray[np.uint8]:
    return np.zeros((0, 4), dtype=np.uint8)


def _prusa_colours(text: str) -> NDArray[np.uint8]:
    values: dict[str, list[str]] = {}
    for line in text.splitlines():
        key, _, value = line.lstrip("; ").partition(" = ")
        if key in ("extruder_colour", "filament_colour"):
            values[key] = [v.strip().strip('"') for v in value.split(";")]
    extruder, filament = values.get("extruder_colour", []), values.get("filament_colour", [])
    chosen = [
        e or (filament[i] if i < len(filament) else "") for i, e in enumerate(extruder or filament)
    ]
    return _colours(Path(PRUSA_CONFIG), chosen)


def _colours(path: Path, values: list[str]) -> NDArray[np.uint8]:
    """``#RRGGBB`` strings as ``(E, 4) uint8``; an empty or malformed one is white."""
    rows = []
    for value in values:
        text = value.strip().lstrip("#")
        try:
            rgb = bytes.fromhex(text[:6]) if len(text) in (6, 8) else b""
        except ValueError:
            rgb = b""
        rows.append([*rgb, 255] if len(rgb) == 3 else [255, 255, 255, 255])
    return np.array(rows, dtype=np.uint8).reshape(-1, 4)


def _xml(path: Path, archive: zipfile.ZipFile, name: str) -> ElementTree.Element:
    try:
        return ElementTree.fromstring(read_entry(path, archive, name))
    except (ElementTree.ParseError, LookupError) as error:  # Lookup: an unknown encoding
        raise InputError(path, f"{name} is malformed XML ({error})", "re-save it") from None


def _metadata(element: ElementTree.Element) -> dict[str, str]:
    return {m.get("key", ""): m.get("value", "") for m in element.findall("metadata")}


def _extruder(path: Path, value: str | None) -> int:
    try:
        number = int(value or 0)
    except ValueError:
        raise InputError(path, f"has a malformed extruder number {value!r}", "re-save it") from None
    return max(number, 0)


def _prusa_model(path: Path, root: ElementTree.Element, project: SlicerProject) -> None:
    for obj in root.iter("object"):
        oid = obj.get("id", "")
        project.object_extruder[oid] = _extruder(path, _metadata(obj).get("extruder"))
        volumes = project.volumes.setdefault(oid, [])
        for volume in obj.iter("volume"):
            meta = _metadata(volume)
            first = _extruder(path, volume.get("firstid"))
            last = _extruder(path, volume.get("lastid"))
            kind = meta.get("volume_type", "ModelPart")
            if meta.get("modifier") == "1":
                kind = "ParameterModifier"
            extruder = _extruder(path, meta.get("extruder"))
            volumes.append((first, last, extruder, kind in MODEL_PARTS))


def _bambu_model(path: Path, root: ElementTree.Element, project: SlicerProject) -> None:
    for obj in root.iter("object"):
        oid = obj.get("id", "")
        project.object_extruder[oid] = _extruder(path, _metadata(obj).get("extruder"))
        for part in obj.iter("part"):
            extruder = _extruder(path, _metadata(part).get("extruder"))
            kind = part.get("subtype", "normal_part")
            project.parts[(oid, part.get("id", ""))] = (extruder, kind in MODEL_PARTS)
