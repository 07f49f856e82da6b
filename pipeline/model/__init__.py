"""The coloured model every stage works on.

- :mod:`~shellvox.model._mesh` ``ColouredMesh`` and the one function that colours the surface;
- :mod:`~shellvox.model._texture` materials and texture sampling;
- :mod:`~shellvox.model._topology` seams merged, degenerate faces dropped, closed, oriented;
- :mod:`~shellvox.model._summary` what ``shellvox info`` reports.
"""

from __future__ import annotations

from shellvox.model._mesh import ColouredMesh
from shellvox.model._summary import summarise
from shellvox.model._texture import FilterMode, Material, WrapMode
from shellvox.model._topology import (
    edge_report,
    face_areas,
    merge_by_position,
    prepare,
    signed_volume,
)

__all__ = [
    "ColouredMesh",
    "FilterMode",
    "Material",
    "WrapMode",
    "edge_report",
    "face_areas",
    "merge_by_position",
    "prepare",
    "signed_volume",
    "summarise",
]
