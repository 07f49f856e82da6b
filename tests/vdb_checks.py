"""What a test or a benchmark reads back from an OpenVDB file, to compare with a manifest."""

from __future__ import annotations

from typing import Any


def describe_grids(grids: Any) -> dict[str, Any]:
    """Return ``{name: {class, value_type, active_voxels, voxel_size_mm}}`` of OpenVDB grids."""
    return {
        volume.name: {
            "class": str(volume.gridClass),
            "value_type": volume.valueTypeName,
            "active_voxels": int(volume.activeVoxelCount()),
            "voxel_size_mm": [float(v) for v in volume.transform.voxelSize()],
        }
        for volume in grids
    }
