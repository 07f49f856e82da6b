"""Load any coloured model users bring into a :class:`~pipeline.mesh.ColouredMesh` in mm.

Formats: OBJ (+MTL, textures), PLY, glTF/GLB, 3MF, STL, OFF. Every loader returns the
raw mesh in file units; this module converts units, applies ``--colour``, checks for
NaN/inf and absurd sizes, then :func:`pipeline.topology.prepare` merges and checks it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from pipeline.config import UNIT_MM, LoadOptions
from pipeline.errors import InputError, ShellvoxWarning
from pipeline.loading.obj import read_obj
from pipeline.loading.threemf import read_3mf
from pipeline.loading.trimesh_formats import read_with_trimesh
from pipeline.mesh import ColouredMesh
from pipeline.topology import prepare

#: Largest coordinate accepted (mm, after units and scale): far past any print, and far
#: below where squared distances and areas overflow.
MAX_COORDINATE_MM = 1e12

FORMATS = {
    ".obj": "obj",
    ".ply": "ply",
    ".glb": "glb",
    ".gltf": "gltf",
    ".3mf": "3mf",
    ".stl": "stl",
    ".off": "off",
}


def load_model(path: str | Path, options: LoadOptions | None = None) -> ColouredMesh:
    """Read a model file, convert it to millimetres, and check it is a printable solid.

    Parameters
    ----------
    path : str or Path
        Model file; the format is chosen by suffix (``.obj .ply .glb .gltf .3mf .stl .off``).
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
    """
    options = options or LoadOptions()
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file not found", "check the path")
    if not path.is_file():
        raise InputError(path, "is not a file", "give the path of a model file")
    file_type = FORMATS.get(path.suffix.lower())
    if file_type is None:
        raise InputError(
            path,
            f"unknown model format {path.suffix or '(no suffix)'!r}",
            f"use one of {', '.join(sorted(FORMATS))}",
        )
    if path.stat().st_size == 0:
        raise InputError(path, "is empty (0 bytes)", "export the model again")
    if options.scale <= 0 or not np.isfinite(options.scale):
        raise InputError(
            "--scale", f"must be a positive number, got {options.scale}", "pass e.g. --scale 25.4"
        )
    if options.texture is not None and not Path(options.texture).is_file():
        raise InputError(options.texture, "texture file not found", "check the --texture path")

    mm_per_unit = UNIT_MM[options.units or "mm"]
    if file_type == "obj":
        mesh = read_obj(path, options)
    elif file_type == "3mf":
        mesh, declared = read_3mf(path)
        if options.units is not None and UNIT_MM[options.units] != declared:
            import warnings

            warnings.warn(
                f"{path}: the 3MF declares its own unit; --units {options.units} "
                "is ignored (use --scale to resize)",
                ShellvoxWarning,
                stacklevel=2,
            )
        mm_per_unit = declared
    else:
        mesh = read_with_trimesh(path, file_type)

    if len(mesh.faces) > options.max_faces and not options.force:
        raise InputError(
            path,
            f"has {len(mesh.faces):,} faces, more than the limit of {options.max_faces:,}",
            "decimate it, or pass --force",
        )
    if not np.isfinite(mesh.vertices).all():
        bad = int((~np.isfinite(mesh.vertices)).any(axis=1).sum())
        raise InputError(
            path,
            f"has {bad} vertices with NaN or infinite coordinates",
            "fix or re-export the model",
        )
    with np.errstate(over="ignore"):
        vertices = mesh.vertices * (mm_per_unit * options.scale)
    reach = float(np.abs(vertices).max(initial=0.0))
    if not reach <= MAX_COORDINATE_MM:  # also inf: later arithmetic would overflow
        raise InputError(
            path,
            f"has coordinates up to {reach:.3g} mm once scaled (unit {mm_per_unit:g} mm, "
            f"--scale {options.scale:g}), past the {MAX_COORDINATE_MM:g} mm shellvox computes with",
            "check --units and --scale, or the file's coordinates",
        )
    mesh = dataclasses.replace(mesh, vertices=vertices, source=str(path))
    if mesh.colour_kind == "none" and options.colour is not None:
        face_rgba = np.tile(np.asarray(options.colour, np.uint8), (len(mesh.faces), 1))
        mesh = dataclasses.replace(mesh, colour_kind="face", face_rgba=face_rgba)
    return prepare(mesh, repair=options.repair)
