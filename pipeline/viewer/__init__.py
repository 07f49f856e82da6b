"""``shellvox view``: a local web viewer of a build's slices.

See :mod:`shellvox.viewer._server`.
"""

from __future__ import annotations

from shellvox.viewer._folder import BuildFolder
from shellvox.viewer._proof import FaceProof, de_scale, face_proof
from shellvox.viewer._sections import (
    MIDDLE,
    VIVID_SPAN,
    SectionCounts,
    choose_section,
)
from shellvox.viewer._server import STATIC, ViewerServer
from shellvox.viewer._slices import probe
from shellvox.viewer._stacks import Axis, StackError, StripCache, TiffStack
from shellvox.viewer._surface import MAX_FACES, Overview, SurfaceMesh

__all__ = [
    "MAX_FACES",
    "MIDDLE",
    "STATIC",
    "VIVID_SPAN",
    "Axis",
    "BuildFolder",
    "FaceProof",
    "Overview",
    "SectionCounts",
    "StackError",
    "StripCache",
    "SurfaceMesh",
    "TiffStack",
    "ViewerServer",
    "choose_section",
    "de_scale",
    "face_proof",
    "probe",
]
