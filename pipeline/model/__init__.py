"""The coloured model every stage works on.

- :mod:`~shellvox.model._mesh` ``ColouredMesh`` and the one function that colours the surface;
- :mod:`~shellvox.model._texture` materials and texture sampling;
- :mod:`~shellvox.model._topology` seams merged, degenerate faces dropped, closed, oriented,
  parts repaired one by one;
- :mod:`~shellvox.model._solid` a mesh as it comes made printable: its inside by the
  winding number, its visible faces;
- :mod:`~shellvox.model._soup` what a mesh is as it comes: holes, parts, overlaps, buried faces;
- :mod:`~shellvox.model._summary` what ``shellvox info`` reports.
"""

from __future__ import annotations

from shellvox.model._mesh import ColouredMesh, Solid
from shellvox.model._solid import SolidReport, needs_solid, solid_model
from shellvox.model._soup import SoupReport, inspect_soup
from shellvox.model._summary import summarise
from shellvox.model._texture import FilterMode, Material, WrapMode
from shellvox.model._topology import (
    clean,
    edge_report,
    face_areas,
    face_parts,
    merge_by_position,
    prepare,
    repair_parts,
    signed_volume,
)

__all__ = [
    "ColouredMesh",
    "FilterMode",
    "Material",
    "Solid",
    "SolidReport",
    "SoupReport",
    "WrapMode",
    "clean",
    "edge_report",
    "face_areas",
    "face_parts",
    "inspect_soup",
    "merge_by_position",
    "needs_solid",
    "prepare",
    "repair_parts",
    "signed_volume",
    "solid_model",
    "summarise",
]
