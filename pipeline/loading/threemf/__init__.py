"""3MF: the package, property groups, multiproperties, slicer paint and the reader."""

from __future__ import annotations

from shellvox.loading.threemf._paint_tree import SCALE, decode
from shellvox.loading.threemf._reader import read_3mf

__all__ = [
    "SCALE",
    "decode",
    "read_3mf",
]
