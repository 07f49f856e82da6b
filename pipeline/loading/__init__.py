"""Load any coloured model users bring into a :class:`~shellvox.model._mesh.ColouredMesh` in mm.

Formats: OBJ (+MTL, textures), PLY, glTF/GLB, 3MF, STL, OFF, VRML 2.0, each a reader
registered by suffix (:func:`register_format`; :data:`FORMATS`). Every reader returns the
raw mesh in file units (and the file's own unit where it declares one, as 3MF does); this
module converts units, applies ``--colour``, checks for NaN/inf and absurd sizes, then
:func:`shellvox.model._topology.prepare` merges and checks it.

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
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.config import UNIT_MM, LoadOptions
from shellvox.errors import InputError, opt, warn
from shellvox.loading._images import MAX_TEXTURE_PIXELS
from shellvox.loading._sniff import check_content
from shellvox.loading._trimesh_formats import read_with_trimesh
from shellvox.loading.gltf import read_gltf
from shellvox.loading.obj import read_obj
from shellvox.loading.threemf import read_3mf
from shellvox.loading.vrml import read_vrml
from shellvox.model import ColouredMesh, prepare

__all__ = [
    "FORMATS",
    "MAX_COORDINATE_MM",
    "MAX_TEXTURE_PIXELS",
    "Format",
    "load_model",
    "register_format",
]

#: Largest distance of a vertex from the origin accepted without ``--force`` (1 km).
MAX_COORDINATE_MM = 1e6
#: Largest accepted even with ``--force`` (1000 km: the float64 spacing there is 1e-7 mm).
MAX_COORDINATE_MM_FORCED = 1e9

#: A reader: the raw mesh of a file in its units and, where the file declares its unit,
#: millimetres per unit (None: ``--units``, default mm).
Reader = Callable[[Path, LoadOptions], tuple[ColouredMesh, float | None]]


class Format(NamedTuple):
    """A model format: its name and its reader."""

    name: str
    read: Reader


_REGISTRY: dict[str, Format] = {}
#: The formats by suffix (lower case, with the dot), as registered (read-only).
FORMATS: Mapping[str, Format] = MappingProxyType(_REGISTRY)


def register_format(suffix: str, name: str, read: Reader) -> None:
    """Read the files whose suffix is `suffix` (any case) with `read`, as format `name`."""
    _REGISTRY[suffix.lower()] = Format(name, read)


def _no_unit(read: Callable[[Path, LoadOptions], ColouredMesh]) -> Reader:
    """Return `read` as a reader of a format without units (the numbers are ``--units``)."""
    return lambda path, options: (read(path, options), None)


def _by_trimesh(file_type: str) -> Reader:
    """Return the reader of a format that trimesh reads (``read_with_trimesh``)."""
    return lambda path, options: (read_with_trimesh(path, file_type, options), None)


register_format(".obj", "obj", _no_unit(read_obj))
register_format(".ply", "ply", _by_trimesh("ply"))
register_format(".glb", "glb", _no_unit(read_gltf))
register_format(".gltf", "gltf", _no_unit(read_gltf))
register_format(".3mf", "3mf", read_3mf)
register_format(".stl", "stl", _by_trimesh("stl"))
register_format(".off", "off", _by_trimesh("off"))
register_format(".wrl", "wrl", _no_unit(read_vrml))


def load_model(path: str | Path, options: LoadOptions | None = None) -> ColouredMesh:
    """Read a model file, convert it to millimetres, and check it is a printable solid.

    Parameters
    ----------
    path : str or Path
        Model file; the format is chosen by suffix (``.obj .ply .glb .gltf .3mf .stl .off
        .wrl``).
    options : LoadOptions, optional
        Units, scale, fallback colour and texture, repair and size limits.

    Returns
    -------
    ColouredMesh
        Closed, consistently outward-oriented, vertices merged by position, in mm.

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
                f"{opt('units', options.units)} is ignored (use {opt('scale')} to resize)",
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
    mesh = dataclasses.replace(
        mesh,
        vertices=_checked_mm(path, mesh.vertices, mm_per_unit * options.scale, options),
        source=str(path),
    )
    if mesh.colour_kind == "none" and options.colour is not None:
        face_rgba = np.tile(np.asarray(options.colour, np.uint8), (len(mesh.faces), 1))
        mesh = dataclasses.replace(mesh, colour_kind="face", face_rgba=face_rgba)
    return prepare(mesh, repair=options.repair)


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
