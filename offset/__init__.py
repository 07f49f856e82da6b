"""Inward per-face offset surfaces (shells) of closed triangle meshes.

Lengths are millimetres; points are ``(x, y, z)``; signed distance is negative inside.
The subpackages: :mod:`~shellvox.offset.field` (the default method: the layer field
meshed and simplified), :mod:`~shellvox.offset.crossing` (crossing tests),
:mod:`~shellvox.offset.quality` (measures and the report) and
:mod:`~shellvox.offset.reference` (the reference methods ``robust`` and ``paper``).
This package never imports the stages; of :mod:`shellvox.voxel` it uses
:mod:`shellvox.voxel.geometry._nearest` (libigl's point queries) and, in the field
method, the voxels' own scan of the nearest faces.
"""

from shellvox.offset.field.step import (
    MAX_FIELD_TRIANGLES,
    SHELL_STEP_MM,
    automatic_lattice,
    automatic_step,
    lattice_cell_mm,
)
from shellvox.offset.methods import (
    DEFAULT_METHOD,
    METHODS,
    Method,
    MethodName,
    MethodShells,
    ShellCost,
    field_shells,
    method_shells,
    offset_shells,
    ready_for_file,
)
from shellvox.offset.quality.report import shell_report
from shellvox.offset.shells import Shell

__all__ = [
    "DEFAULT_METHOD",
    "MAX_FIELD_TRIANGLES",
    "METHODS",
    "SHELL_STEP_MM",
    "Method",
    "MethodName",
    "MethodShells",
    "Shell",
    "ShellCost",
    "automatic_lattice",
    "automatic_step",
    "field_shells",
    "lattice_cell_mm",
    "method_shells",
    "offset_shells",
    "ready_for_file",
    "shell_report",
]
