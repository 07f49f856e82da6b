"""The Python API: what each ``shellvox`` command does, as functions over paths and arrays.

Each function checks its input at the boundary (bad input raises an
:class:`~shellvox.errors.InputError`, a ``ValueError`` naming the file or option, the
problem and the fix) and returns what it made as a small frozen result object. The
command line (:mod:`shellvox.cli`) parses its options into the same frozen configurations
and calls these functions. Every name here is also a name of :mod:`shellvox`.
"""

from __future__ import annotations

from shellvox.api._build import (
    BuildOptions,
    BuildResult,
    TrayRequest,
    build,
    build_tray,
    plan_tray_build,
)
from shellvox.api._chart import Calibration, ChartResult, calibrate, make_chart
from shellvox.api._fdm import FdmResult, fdm_projects
from shellvox.api._inspect import Inspection, inspect_build, summary_rows
from shellvox.api._shells import ShellsResult, write_shells
from shellvox.api._thickness import ThicknessChoice, layer_thickness
from shellvox.kernel_cache import announce_compiling
from shellvox.offset import offset_shells

announce_compiling()  # the first compilation on a machine says so, once

__all__ = [
    "BuildOptions",
    "BuildResult",
    "Calibration",
    "ChartResult",
    "FdmResult",
    "Inspection",
    "ShellsResult",
    "ThicknessChoice",
    "TrayRequest",
    "build",
    "build_tray",
    "calibrate",
    "fdm_projects",
    "inspect_build",
    "layer_thickness",
    "make_chart",
    "offset_shells",
    "plan_tray_build",
    "summary_rows",
    "write_shells",
]
