"""The coloured model every stage works on.

- :mod:`~pipeline.model._mesh` ``ColouredMesh`` and the one function that colours the surface;
- :mod:`~pipeline.model._texture` materials and texture sampling;
- :mod:`~pipeline.model._topology` seams merged, degenerate faces dropped, closed, oriented;
- :mod:`~pipeline.model._summary` what ``shellvox info`` reports.
"""

from __future__ import annotations

from pipeline.model._mesh import ColouredMesh
from pipeline.model._summary import summarise
from pipeline.model._texture import FilterMode, Material, WrapMode
from pipeline.model._topology import (
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
