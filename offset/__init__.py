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

from shellvox.offset.quality.report import shell_report
from shellvox.offset.shells import METHODS, Shell, offset_shells

__all__ = ["METHODS", "Shell", "offset_shells", "shell_report"]
