"""``volume.vdb`` written without OpenVDB, streamed slab by slab.

Leaves cut from voxel rows (:mod:`~shellvox.voxel.io.vdb._encode`), encoded and spooled
(:mod:`~shellvox.voxel.io.vdb._leaves`), the file and its tree
(:mod:`~shellvox.voxel.io.vdb._format`), the writer (:mod:`~shellvox.voxel.io.vdb._writer`).
"""

from __future__ import annotations

from shellvox.voxel.io.vdb._encode import GRID_NAMES, MATERIAL_GRID, VdbEncoder
from shellvox.voxel.io.vdb._leaves import GridSpool
from shellvox.voxel.io.vdb._writer import VdbStackWriter

__all__ = [
    "GRID_NAMES",
    "MATERIAL_GRID",
    "GridSpool",
    "VdbEncoder",
    "VdbStackWriter",
]
