"""``shellvox view``: a local web viewer of a build's slices.

See :mod:`pipeline.viewer._server`.
"""

from __future__ import annotations

from pipeline.viewer._folder import BuildFolder
from pipeline.viewer._sections import (
    MIDDLE,
    VIVID_SPAN,
    SectionCounts,
    choose_section,
)
from pipeline.viewer._server import STATIC, ViewerServer
from pipeline.viewer._slices import probe
from pipeline.viewer._stacks import Axis, StackError, StripCache, TiffStack
from pipeline.viewer._surface import MAX_FACES, Overview, SurfaceMesh

__all__ = [
    "MAX_FACES",
    "MIDDLE",
    "STATIC",
    "VIVID_SPAN",
    "Axis",
    "BuildFolder",
    "Overview",
    "SectionCounts",
    "StackError",
    "StripCache",
    "SurfaceMesh",
    "TiffStack",
    "ViewerServer",
    "choose_section",
    "probe",
]
