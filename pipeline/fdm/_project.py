"""An FDM project: the skin depth per face, the filament per face, the parts, the placement.

Everything the 3MF writers serialise is decided here, as arrays
(:func:`plan_project`); the writers (:mod:`shellvox.fdm._prusa`, :mod:`shellvox.fdm._bambu`)
only format it.

Depth rules (documented in the README):

- the skin's depth per face is the colour layer's (the first row of the thickness); the
  layers behind it are the core's filament, which is what backs the colour;
- a depth below the nozzle width is refused (:class:`shellvox.errors.FdmError`): the slicer
  cannot lay a line there; one below one extrusion width (``1.125 x`` nozzle, PrusaSlicer's
  default perimeter width) is raised to it when asked (``lift=True``, the thickness rule's
  depths, made for a jetting printer);
- on faces that face up or down (``|n_z| >= cos 45 deg``) the skin is printed as whole
  layers: their depth is rounded up to a whole number of layers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.config import check_lengths, check_number
from shellvox.errors import FdmError, InputError, opt
from shellvox.fdm._filaments import Filaments
from shellvox.fdm._parts import FdmPart, face_normals, plan_parts

#: Filaments each slicer's project takes: PrusaSlicer's painting and extruder states stop at
#: 15 (``EnforcerBlockerType::Extruder15``, ``Model.hpp``); Bambu Studio's AMS slots at 16.
MAX_FILAMENTS = {"prusa": 15, "bambu": 16}
#: Extrusion width per nozzle width (PrusaSlicer's default perimeter width).
WIDTH_PER_NOZZLE = 1.125
#: A face is printed as layers (top or bottom skin) when ``|n_z|`` is at least this.
FLAT_NZ = math.cos(math.radians(45.0))

Shells = Callable[[NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.int64]]]


@dataclass(frozen=True)
class FdmSettings:
    """Printer settings written into the projects.

    Attributes
    ----------
    layer_height_mm : float
    nozzle_mm : float
    bed_mm : (float, float)
        Bed size; the object is placed at its centre.
    wipe_tower_mm : (float, float)
        The wipe tower's corner.
    """

    layer_height_mm: float = 0.2
    nozzle_mm: float = 0.4
    bed_mm: tuple[float, float] = (250.0, 210.0)
    wipe_tower_mm: tuple[float, float] = (20.0, 170.0)

    def __post_init__(self) -> None:
        """Check every value once, naming the parameter and the allowed values."""
        check_number("fdm_layer_height", self.layer_height_mm, low=0, strict=True)
        check_number("nozzle", self.nozzle_mm, low=0, strict=True)
        object.__setattr__(self, "bed_mm", check_lengths("bed", self.bed_mm, count=2))
        corner: Any = self.wipe_tower_mm
        if isinstance(corner, str | bytes) or not isinstance(corner, Iterable):
            corner = ()
        corner = tuple(corner)
        if len(corner) != 2:
            raise InputError(
                opt("wipe_tower"), f"got {self.wipe_tower_mm!r}", "give (x, y) in mm on the bed"
            )
        for value in corner:
            check_number("wipe_tower", value, low=0)
        object.__setattr__(self, "wipe_tower_mm", tuple(float(v) for v in corner))


@dataclass(frozen=True, eq=False)
class FdmProject:
    """What the writers serialise.

    Attributes
    ----------
    name : str
    parts : tuple of FdmPart
        In slicing order (:func:`shellvox.fdm._parts.plan_parts`).
    filaments : Filaments
    settings : FdmSettings
    placement_mm : (3,) float64, mm
        Translation of the object onto the bed (centred, lowest point at z = 0).
    face_filament : (F,) int64
        Skin filament per face of the model (0-based).
    depth_mm : (F,) float64, mm
        Skin depth per face as used (after lifting and snapping).
    """

    name: str
    parts: tuple[FdmPart, ...]
    filaments: Filaments
    settings: FdmSettings
    placement_mm: NDArray[np.float64]
    face_filament: NDArray[np.int64]
    depth_mm: NDArray[np.float64]


def check_filament_count(filaments: Filaments, slicers: tuple[str, ...]) -> None:
    """Refuse more filaments than a chosen slicer's project takes."""
    for slicer in slicers:
        if len(filaments) > MAX_FILAMENTS[slicer]:
            raise FdmError(
                opt("filaments"),
                f"{len(filaments)} filaments, but a {slicer} project takes at most "
                f"{MAX_FILAMENTS[slicer]}",
                f"merge similar colours or leave that slicer out of {opt('slicer')}",
            )


def skin_depth(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    depth_mm: NDArray[np.float64],
    settings: FdmSettings,
    *,
    lift: bool = False,
) -> NDArray[np.float64]:
    """Return the skin depth per face that prints: checked, lifted and snapped to layers.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    depth_mm : (F,) float64, mm
        The colour layer's depth per face.
    settings : FdmSettings
    lift : bool
        Raise depths below one extrusion width to it instead of refusing those below
        the nozzle width.

    Raises
    ------
    FdmError
        A depth below the nozzle width (without `lift`).

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((20.0, 20.0, 10.0))
    >>> d = skin_depth(box.vertices, box.faces, np.full(12, 1.1), FdmSettings())
    >>> sorted(set(np.round(d, 3).tolist()))
    [1.1, 1.2]
    """
    depth = np.asarray(depth_mm, np.float64).copy()
    width = WIDTH_PER_NOZZLE * settings.nozzle_mm
    if not lift and depth.min() < settings.nozzle_mm:
        raise FdmError(
            opt("thickness"),
            f"a skin depth of {depth.min():.3g} mm is below the nozzle width "
            f"({settings.nozzle_mm:g} mm)",
            f"pass at least {opt('thickness', float(f'{width:g}'))} (one extrusion width)",
        )
    depth = np.maximum(depth, width)
    flat = np.abs(face_normals(vertices, faces)[:, 2]) >= FLAT_NZ
    layer = settings.layer_height_mm
    depth[flat] = np.ceil(depth[flat] / layer - 1e-6) * layer
    return depth


def plan_project(
    name: str,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    face_filament: NDArray[np.int64],
    depth_mm: NDArray[np.float64],
    filaments: Filaments,
    settings: FdmSettings,
    shells: Shells,
) -> FdmProject:
    """Return the project: the parts at the given depths, placed on the bed.

    Parameters
    ----------
    name : str
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    face_filament : (F,) int64
    depth_mm : (F,) float64, mm
        Skin depth per face (from :func:`skin_depth`).
    filaments : Filaments
    settings : FdmSettings
    shells : callable
        ``shells(depth_mm) -> (vertices, faces)`` of the inner shell at those depths
        (e.g. :func:`shellvox.offset.offset_shells` with the chosen method).
    """
    core = shells(depth_mm)
    # The patches reach past the skin by one extrusion width; the core clips them.
    reach = depth_mm + WIDTH_PER_NOZZLE * settings.nozzle_mm
    parts = plan_parts(vertices, faces, face_filament, reach, core)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    centre = np.array([settings.bed_mm[0] / 2, settings.bed_mm[1] / 2, 0.0])
    placement = centre - np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]])
    return FdmProject(
        name=name,
        parts=parts,
        filaments=filaments,
        settings=settings,
        placement_mm=placement,
        face_filament=np.asarray(face_filament, np.int64),
        depth_mm=depth_mm,
    )
