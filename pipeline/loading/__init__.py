"""Load any coloured model users bring into a :class:`~shellvox.model._mesh.ColouredMesh` in mm.

Formats: OBJ (+MTL, textures), PLY, glTF/GLB, 3MF, STL, OFF, VRML 2.0, each a reader
registered by suffix (:func:`register_format`; :data:`FORMATS`). Every reader returns the
raw mesh in file units (and the file's own unit where it declares one: 3MF its ``unit``,
glTF metres by its specification); this module turns the format's up axis to +Z, converts
units, applies ``--scale`` or ``--size``, applies ``--colour``, checks for NaN/inf and
absurd sizes, then :func:`shellvox.model._topology.prepare` merges and checks it.

Units and axes by format:

- glTF/GLB: metres, +Y up (its specification). Turned to +Z up as Blender imports it:
  ``(x, y, z) -> (x, -z, y)``, a rotation, so faces stay outward.
- 3MF: its declared ``unit``, +Z up.
- OBJ, PLY, STL, OFF, VRML: no declared unit, read as ``--units`` (default mm), +Z up.

``--up`` names another up axis of the file (turned to +Z by a rotation, :data:`TURNS`);
``--size`` scales the model uniformly so its longest side is that many mm. Without
``--size``, a model whose longest side is under :data:`PLAUSIBLE_MM` ``[0]`` or over
``[1]`` mm is read as it is, with a one-line warning naming ``--units`` and ``--size``.

Every problem ends in a correct load, an :class:`~shellvox.errors.InputError` (one line:
file, problem, fix), or a :class:`~shellvox.errors.ShellvoxWarning` saying what was
changed. In particular:

- A file whose first bytes are plainly not its suffix's format (an image, an archive,
  binary data where text is expected, another model format) is refused before its reader
  runs, naming what it is and, for another model format, the suffix to give it
  (:mod:`shellvox.loading._sniff`).
- Referenced files (MTL, textures, glTF buffers and images, PLY ``TextureFile``) must lie
  in the model's folder or below it (:mod:`shellvox.loading._references`); a reference
  outside is refused unless ``--force`` (then read with a warning).
- A declared colour that cannot be used is refused or, with ``--colour``, replaced by that
  colour with a warning; one the format allows but shellvox does not read is named in a
  warning.
- Limits, each lifted by ``--force``: :data:`MAX_TEXTURE_PIXELS` texture pixels over all
  textures (checked from the image headers before decoding), ``max_faces`` faces, and
  coordinates within :data:`MAX_COORDINATE_MM` of the origin after unit conversion and
  ``--scale``. Beyond :data:`MAX_COORDINATE_MM_FORCED` (where float64 arithmetic on the
  geometry loses its sub-micron precision) and for NaN or infinity there is no ``--force``.
  A glTF buffer may not declare more bytes than the file holds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.config import UNIT_MM, LoadOptions, Up
from shellvox.errors import InputError, opt, warn
from shellvox.loading._images import MAX_TEXTURE_PIXELS
from shellvox.loading._sniff import check_content
from shellvox.loading._trimesh_formats import read_with_trimesh
from shellvox.loading.gltf import read_gltf
from shellvox.loading.obj import read_obj
from shellvox.loading.threemf import read_3mf
from shellvox.loading.vrml import read_vrml
from shellvox.model import ColouredMesh, needs_solid, prepare, solid_model

__all__ = [
    "FORMATS",
    "MAX_COORDINATE_MM",
    "MAX_TEXTURE_PIXELS",
    "PLAUSIBLE_MM",
    "TURNS",
    "Format",
    "load_model",
    "register_format",
]

#: Largest distance of a vertex from the origin accepted without ``--force`` (1 km).
MAX_COORDINATE_MM = 1e6
#: Largest accepted even with ``--force`` (1000 km: the float64 spacing there is 1e-7 mm).
MAX_COORDINATE_MM_FORCED = 1e9
#: Longest sides (mm) of a plausible print; outside them, without ``--size``, a warning.
PLAUSIBLE_MM = (1.0, 1000.0)

#: The rotation that turns each up axis of a file to +Z: ``new[:, i] = sign[i] * old[:, axis[i]]``
#: (each a proper rotation, determinant +1). ``y`` is Blender's glTF import
#: (``(x, y, z) -> (x, -z, y)``), ``x`` a quarter turn about y, ``-z`` a half turn about x.
TURNS: Mapping[Up, tuple[tuple[int, int, int], tuple[float, float, float]]] = MappingProxyType(
    {
        "z": ((0, 1, 2), (1.0, 1.0, 1.0)),
        "y": ((0, 2, 1), (1.0, -1.0, 1.0)),
        "x": ((2, 1, 0), (-1.0, 1.0, 1.0)),
        "-z": ((0, 1, 2), (1.0, -1.0, -1.0)),
        "-y": ((0, 2, 1), (1.0, 1.0, -1.0)),
        "-x": ((2, 1, 0), (1.0, 1.0, -1.0)),
    }
)

#: A reader: the raw mesh of a file in its units and, where the file declares its unit,
#: millimetres per unit (None: ``--units``, default mm).
Reader = Callable[[Path, LoadOptions], tuple[ColouredMesh, float | None]]


class Format(NamedTuple):
    """A model format: its name, its reader and the axis that points up in its files."""

    name: str
    read: Reader
    up: Up = "z"


_REGISTRY: dict[str, Format] = {}
#: The formats by suffix (lower case, with the dot), as registered (read-only).
FORMATS: Mapping[str, Format] = MappingProxyType(_REGISTRY)


def register_format(suffix: str, name: str, read: Reader, up: Up = "z") -> None:
    """Read the files whose suffix is `suffix` (any case) with `read`, as format `name`.

    `up` is the axis that points up in the format's files (turned to +Z on loading).
    """
    _REGISTRY[suffix.lower()] = Format(name, read, up)


def _no_unit(read: Callable[[Path, LoadOptions], ColouredMesh]) -> Reader:
    """Return `read` as a reader of a format without units (the numbers are ``--units``)."""
    return lambda path, options: (read(path, options), None)


def _by_trimesh(file_type: str) -> Reader:
    """Return the reader of a format that trimesh reads (``read_with_trimesh``)."""
    return lambda path, options: (read_with_trimesh(path, file_type, options), None)


def _metres(read: Callable[[Path, LoadOptions], ColouredMesh]) -> Reader:
    """Return `read` as a reader of a format in metres (glTF, by its specification)."""
    return lambda path, options: (read(path, options), UNIT_MM["m"])


register_format(".obj", "obj", _no_unit(read_obj))
register_format(".ply", "ply", _by_trimesh("ply"))
register_format(".glb", "glb", _metres(read_gltf), up="y")
register_format(".gltf", "gltf", _metres(read_gltf), up="y")
register_format(".3mf", "3mf", read_3mf)
register_format(".stl", "stl", _by_trimesh("stl"))
register_format(".off", "off", _by_trimesh("off"))
register_format(".wrl", "wrl", _no_unit(read_vrml))


def load_model(
    path: str | Path,
    options: LoadOptions | None = None,
    *,
    size_warning: bool = True,
    check: Literal["refuse", "report", "solid"] = "refuse",
) -> ColouredMesh:
    """Read a model file, turn it +Z up, convert it to millimetres, check it is a printable solid.

    Parameters
    ----------
    path : str or Path
        Model file; the format is chosen by suffix (``.obj .ply .glb .gltf .3mf .stl .off
        .wrl``).
    options : LoadOptions, optional
        Units, scale or size, up axis, fallback colour and texture, repair and size limits.
    size_warning : bool
        Warn when the model's longest side is implausible for a print (:data:`PLAUSIBLE_MM`)
        and no ``size_mm`` is given; False for a caller that scales the model itself (a
        tray entry's ``scale`` or ``size``).
    check : {"refuse", "report", "solid"}
        ``"refuse"``: refuse a mesh that is not a closed, oriented solid. ``"report"``:
        return it merged and cleaned as it is, open or not, for a report of it (``shellvox
        info``; :func:`shellvox.model.inspect_soup`); files that are no model (unreadable,
        no faces) are still refused. ``"solid"``: read a mesh as it comes, open, of
        overlapping parts or inside out, as the solid its winding number makes
        (:func:`shellvox.model.solid_model`; what ``build`` does).

    Returns
    -------
    ColouredMesh
        Closed, consistently outward-oriented, vertices merged by position, in mm, +Z up;
        ``loaded`` says how it was read (format, unit, up axis, scale, size).

    Raises
    ------
    InputError
        A ``ValueError`` whose message names the file, the problem and the fix.

    Examples
    --------
    >>> import numpy as np
    >>> import shellvox
    >>> mesh = shellvox.load_model(shellvox.data.colour_target())
    >>> mesh.faces.shape, np.ptp(mesh.vertices, axis=0).round(2).tolist()  # mm
    ((3468, 3), [24.0, 16.0, 6.0])
    >>> inch = shellvox.load_model(shellvox.data.colour_target(), shellvox.LoadOptions(scale=0.5))
    >>> np.ptp(inch.vertices, axis=0).round(2).tolist()
    [12.0, 8.0, 3.0]
    """
    options = options or LoadOptions()
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file not found", "check the path")
    if not path.is_file():
        raise InputError(path, "is not a file", "give the path of a model file")
    found = FORMATS.get(path.suffix.lower())
    if found is None:
        raise InputError(
            path,
            f"unknown model format {path.suffix or '(no suffix)'!r}",
            f"use one of {', '.join(sorted(FORMATS))}",
        )
    if path.stat().st_size == 0:
        raise InputError(path, "is empty (0 bytes)", "export the model again")
    check_content(path, found.name)
    if options.scale <= 0 or not np.isfinite(options.scale):
        raise InputError(
            opt("scale"),
            f"must be a positive number, got {options.scale}",
            f"pass e.g. {opt('scale', 25.4)}",
        )
    if options.texture is not None and not Path(options.texture).is_file():
        raise InputError(
            options.texture, "texture file not found", f"check the path of {opt('texture')}"
        )
    if options.texture is not None and found.name != "obj":
        warn(
            f"{opt('texture')} applies to OBJ files only; {path.name} is read without it",
        )

    mm_per_unit = UNIT_MM[options.units or "mm"]
    mesh, declared = found.read(path, options)
    if declared is not None:
        if options.units is not None and UNIT_MM[options.units] != declared:
            warn(
                f"{path}: the {found.name.upper()} declares its own unit; "
                f"{opt('units', options.units)} is ignored (use {opt('size')} or {opt('scale')} "
                "to resize)",
            )
        mm_per_unit = declared

    if len(mesh.faces) > options.max_faces and not options.force:
        raise InputError(
            path,
            f"has {len(mesh.faces):,} faces, more than the limit of {options.max_faces:,}",
            f"decimate it, or pass {opt('force')}",
        )
    if not np.isfinite(mesh.vertices).all():
        bad = int((~np.isfinite(mesh.vertices)).any(axis=1).sum())
        raise InputError(
            path,
            f"has {bad} vertices with NaN or infinite coordinates",
            "fix or re-export the model",
        )
    up = options.up or found.up
    axis, sign = TURNS[up]
    vertices = mesh.vertices[:, list(axis)] * np.asarray(sign)  # exact: a signed permutation
    used = np.zeros(len(vertices), dtype=bool)
    used[mesh.faces.ravel()] = True  # unused vertices are dropped by prepare: not measured
    factor = mm_per_unit * options.scale
    if options.size_mm is not None and used.any():  # no faces: refused by prepare
        factor = options.size_mm / _longest_side(path, vertices[used])
    vertices = _checked_mm(path, vertices, factor, options)
    if options.size_mm is None and size_warning and used.any():
        _warn_implausible(path, vertices[used], found.name, declared, options)
    loaded: dict[str, Any] = {
        "format": found.name,
        "unit": _unit_name(mm_per_unit),
        "mm_per_unit": mm_per_unit,
        "unit_from": "file" if declared is not None else "option" if options.units else "default",
        "up": up,
        "up_from": "option" if options.up else "format",
        "scale": options.scale,
        "size_mm": options.size_mm,
        "mm_per_file_unit": factor,
    }
    mesh = dataclasses.replace(mesh, vertices=vertices, source=str(path), loaded=loaded)
    if mesh.colour_kind == "none" and options.colour is not None:
        face_rgba = np.tile(np.asarray(options.colour, np.uint8), (len(mesh.faces), 1))
        mesh = dataclasses.replace(mesh, colour_kind="face", face_rgba=face_rgba)
    if check != "solid":
        return prepare(mesh, repair=options.repair, check=check)
    mesh = prepare(mesh, repair=options.repair, check="report")
    if not needs_solid(mesh):
        return prepare(mesh)  # one closed part: checked (and turned outside out) as ever
    solid, done = solid_model(mesh)
    warn(f"{path}: read as it comes: {done.line()}")
    return dataclasses.replace(solid, loaded={**solid.loaded, "as_it_comes": done._asdict()})


def _unit_name(mm_per_unit: float) -> str | None:
    """Return the name of a unit of :data:`shellvox.config.UNIT_MM` (None: none of them)."""
    return next((name for name, mm in UNIT_MM.items() if mm == mm_per_unit), None)


def _longest_side(path: Path, vertices: NDArray[np.float64]) -> float:
    """Return the longest side of the bounding box of finite `vertices` ``(V, 3)``, file units.

    Raises
    ------
    InputError
        The model has no extent (every vertex at one point) or one beyond float range.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        longest = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    if not 0 < longest < np.inf:
        raise InputError(
            opt("size"),
            f"{path}: the model's longest side is {longest:g} file units, which no size "
            "can be scaled from",
            "check the file",
        )
    return longest


def _warn_implausible(
    path: Path,
    vertices: NDArray[np.float64],
    format_name: str,
    declared: float | None,
    options: LoadOptions,
) -> None:
    """Warn in one line when the longest side of `vertices` (mm) is no plausible print's.

    Outside :data:`PLAUSIBLE_MM`; the warning says how the unit was read and names
    ``--size`` (and ``--units`` for a format that declares no unit).
    """
    longest = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    low, high = PLAUSIBLE_MM
    if low <= longest <= high:
        return
    kind = "small" if longest < low else "large"
    if declared is not None:
        unit = _unit_name(declared) or f"units of {declared:g} mm"
        read = f"read in {unit}, the {format_name.upper()}'s unit"
        fix = f"pass the longest side you want ({opt('size', 50)}) or {opt('scale')}"
    else:
        unit = options.units or "mm"
        read = f"read as {unit}" + ("" if options.units else f": {format_name.upper()} has no unit")
        fix = f"pass the file's unit ({opt('units')}) or the longest side you want " + (
            f"({opt('size', 50)})"
        )
    warn(
        f"{path}: the model is {longest:.3g} mm at its longest ({read}), implausibly {kind} "
        f"for a print; {fix}",
    )


def _checked_mm(
    path: Path, vertices: NDArray[np.float64], factor: float, options: LoadOptions
) -> NDArray[np.float64]:
    """Scale file-unit vertices to mm and refuse coordinates no printer can hold.

    Parameters
    ----------
    vertices : (V, 3) float64
        Finite, in file units.
    factor : float
        Millimetres per file unit times ``--scale``.

    Returns
    -------
    (V, 3) float64, mm
    """
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = vertices * factor
        largest = float(np.abs(scaled).max()) if scaled.size else 0.0
    if not np.isfinite(scaled).all():
        raise InputError(
            opt("scale"),
            f"{path}: coordinates of up to {float(np.abs(vertices).max()):.3g} file units times "
            f"{factor:g} mm per unit overflow to infinity",
            f"pass a smaller {opt('scale')} or the right {opt('units')}",
        )
    limit = MAX_COORDINATE_MM_FORCED if options.force else MAX_COORDINATE_MM
    if largest > limit:
        fix = f"check {opt('units')} and {opt('scale')} (or the file)" + (
            "" if options.force else f", or pass {opt('force')}"
        )
        raise InputError(
            path,
            f"has coordinates up to {largest:.3g} mm from the origin after unit conversion and "
            f"scaling, beyond the limit of {limit:.0e} mm",
            fix,
        )
    return scaled
