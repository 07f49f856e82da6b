"""FDM projects: the colour skin over a core as a 3MF project per slicer.

:func:`make_project` maps every face's colour to the nearest filament (CIEDE2000), fixes the
skin depth per face (:func:`pipeline.fdm._project.skin_depth`), and plans the volumes of one
object (:mod:`pipeline.fdm._parts`): the body, a modifier per skin filament, and the core at
the skin depth (:func:`offset.offset_shells`). :func:`write_projects` writes
``<stem>_prusa.3mf`` (PrusaSlicer) and ``<stem>_bambu.3mf`` (Bambu Studio, OrcaSlicer).
"""

from pipeline.fdm._filaments import Filaments, nearest_filament, parse_filaments
from pipeline.fdm._make import SLICERS, check_slicers, make_project, write_projects
from pipeline.fdm._project import MAX_FILAMENTS, FdmProject, FdmSettings

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
