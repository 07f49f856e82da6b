"""FDM projects: the colour skin over a core as a 3MF project per slicer.

:func:`make_project` maps every face's colour to the nearest filament (CIEDE2000), fixes the
skin depth per face (:func:`shellvox.fdm._project.skin_depth`), and plans the volumes of one
object (:mod:`shellvox.fdm._parts`): the body, a modifier per skin filament, and the core at
the skin depth (:func:`shellvox.offset.offset_shells`). :func:`write_projects` writes
``<stem>_prusa.3mf`` (PrusaSlicer) and ``<stem>_bambu.3mf`` (Bambu Studio, OrcaSlicer).
"""

from shellvox.fdm._filaments import Filaments, nearest_filament, parse_filaments
from shellvox.fdm._make import SLICERS, check_slicers, make_project, write_projects
from shellvox.fdm._project import MAX_FILAMENTS, FdmProject, FdmSettings

__all__ = [
    "MAX_FILAMENTS",
    "SLICERS",
    "FdmProject",
    "FdmSettings",
    "Filaments",
    "check_slicers",
    "make_project",
    "nearest_filament",
    "parse_filaments",
    "write_projects",
]
