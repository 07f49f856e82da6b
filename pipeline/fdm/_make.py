"""The FDM project of a coloured model, and its files: the public entry points."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.errors import FdmError, opt
from shellvox.fdm._bambu import write_bambu_3mf
from shellvox.fdm._filaments import Filaments, nearest_filament
from shellvox.fdm._project import (
    MAX_FILAMENTS,
    FdmProject,
    FdmSettings,
    check_filament_count,
    plan_project,
    skin_depth,
)
from shellvox.fdm._prusa import write_prusa_3mf
from shellvox.model import ColouredMesh
from shellvox.offset import offset_shells
from shellvox.offset.adjacency import edge_adjacency
from shellvox.thickness import face_colour

Slicer = Literal["prusa", "bambu"]
SLICERS: tuple[str, ...] = tuple(MAX_FILAMENTS)
WRITERS = {"prusa": write_prusa_3mf, "bambu": write_bambu_3mf}


def check_slicers(slicers: Sequence[str]) -> tuple[str, ...]:
    """Return the slicers, checked against :data:`SLICERS` (no duplicates, at least one)."""
    chosen = tuple(dict.fromkeys(slicers))
    unknown = [s for s in chosen if s not in SLICERS]
    if unknown or not chosen:
        raise FdmError(
            opt("slicer"),
            f"expected some of {', '.join(SLICERS)}, got {','.join(slicers) or 'nothing'}",
            f"pass e.g. {opt('slicer', ('prusa', 'bambu'))}",
        )
    return chosen


def face_neighbours(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Return the three edge neighbours of every face, ``(F, 3) int64``."""
    adj = edge_adjacency(faces)
    left, right = adj.face_left[adj.face_edges], adj.face_right[adj.face_edges]
    own = np.arange(faces.shape[0])[:, None]
    neighbours: NDArray[np.int64] = np.where(left == own, right, left)
    return neighbours


def make_project(
    mesh: ColouredMesh,
    depth_mm: ArrayLike,
    filaments: Filaments,
    *,
    settings: FdmSettings | None = None,
    slicers: Sequence[str] = SLICERS,
    method: str = "field",
    dither: bool = False,
    lift: bool = False,
    name: str = "model",
) -> FdmProject:
    """Return the FDM project of `mesh`: skin filament and depth per face, and the parts.

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, outward-oriented.
    depth_mm : (F,) array_like of float, mm
        The colour layer's depth per face (the skin's, before the rules of
        :func:`shellvox.fdm._project.skin_depth`).
    filaments : Filaments
        The core's first.
    settings : FdmSettings, optional
        Default :class:`FdmSettings()`.
    slicers : sequence of {"prusa", "bambu"}
        Checked for the filament count they take.
    method : str
        :data:`shellvox.offset.METHODS`' method for the core (default ``field``).
    dither : bool
        Dither the filament choice over neighbouring faces (CIELAB error diffusion).
    lift : bool
        Raise depths below one extrusion width instead of refusing those below the nozzle.
    name : str

    Raises
    ------
    FdmError
        Too many filaments for a slicer, or a depth below the nozzle width.
    """
    settings = FdmSettings() if settings is None else settings
    check_filament_count(filaments, check_slicers(slicers))
    v, f = mesh.vertices, mesh.faces
    depth = skin_depth(v, f, np.asarray(depth_mm, np.float64), settings, lift=lift)
    neighbours = face_neighbours(f) if dither else None
    chosen = nearest_filament(face_colour(mesh).lab, filaments, neighbours=neighbours)

    def shells(d: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        shell = offset_shells(v, f, d[None, :], method=method)[0]  # type: ignore[arg-type]
        return shell.vertices, shell.faces

    return plan_project(name, v, f, chosen, depth, filaments, settings, shells)


def write_projects(
    folder: Path, stem: str, project: FdmProject, slicers: Sequence[str]
) -> list[Path]:
    """Write ``folder/<stem>_<slicer>.3mf`` for each slicer; return the paths."""
    return [
        WRITERS[slicer](folder / f"{stem}_{slicer}.3mf", project)
        for slicer in check_slicers(slicers)
    ]
