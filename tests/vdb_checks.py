"""What a test or a benchmark reads back from an OpenVDB file, to compare with a manifest."""

from __future__ import annotations

from typing import Any


def describe_grids(grids: dict[str, Any]) -> dict[str, Any]:
    """Return ``{name: {class, value_type, active_voxels, voxel_size_mm}}`` of grids read by
    :func:`openvdb_process.read_vdb`."""
    return {
        name: {
            "class": volume.grid_class,
            "value_type": volume.value_type,
            "active_voxels": volume.active_voxels,
            "voxel_size_mm": [float(v) for v in volume.voxel_size],
        }
        for name, volume in grids.items()
    }
