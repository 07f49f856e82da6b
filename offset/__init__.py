"""Inward per-face offset surfaces (shells) of closed triangle meshes.

Lengths are millimetres; points are ``(x, y, z)``; signed distance is negative inside.
This package never imports :mod:`pipeline`; of :mod:`voxel` it uses only
:mod:`shellvox.voxel.geometry._nearest`, the one wrapper of libigl's point queries (exact nearest
points and generalised winding numbers), which imports nothing of :mod:`offset`.
"""

from shellvox.offset.report import shell_report
from shellvox.offset.shells import METHODS, Shell, offset_shells

__all__ = ["METHODS", "Shell", "offset_shells", "shell_report"]
