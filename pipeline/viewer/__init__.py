"""``shellvox view``: a local web viewer of a build's slices.

See :mod:`pipeline.viewer._server`.
"""

from __future__ import annotations

from pipeline.viewer._folder import BuildFolder
from pipeline.viewer._inflate import InflateError, decode, pick_bytes
from pipeline.viewer._server import STATIC, ViewerServer
from pipeline.viewer._slices import probe
from pipeline.viewer._stacks import Axis, StackError, SymbolCache, TiffStack

__all__ = [
    "STATIC",
    "Axis",
    "BuildFolder",
    "InflateError",
    "StackError",
    "SymbolCache",
    "TiffStack",
    "ViewerServer",
    "decode",
    "pick_bytes",
    "probe",
]
