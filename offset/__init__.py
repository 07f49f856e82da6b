"""Inward per-face offset surfaces (shells) of closed triangle meshes.

Lengths are millimetres; points are ``(x, y, z)``; signed distance is negative inside.
This package never imports :mod:`pipeline` or :mod:`voxel`.
"""

from offset.report import shell_report
from offset.shells import METHODS, Shell, offset_shells

__all__ = ["METHODS", "Shell", "offset_shells", "shell_report"]
