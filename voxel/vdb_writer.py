"""OpenVDB output through OpenVDB's own Python bindings (serialisation only).

Slabs are copied into four sparse grids that share one linear transform carrying the
anisotropic voxel size, so index ``(i, j, k) = (x, y, z)`` maps to the voxel centre in mm:

- ``density`` (float): 1 inside the model, background 0;
- ``layer`` (float): the layer index, background 0;
- ``color`` (Vec3s): linear RGB of the colour layers, background 0;
- ``sdf`` (float, level set): signed distance to the outer surface in a narrow band,
  background the half width, sign flood-filled on :meth:`VdbStackWriter.write`.

OpenVDB files cannot be appended, so the grids live in memory (sparse: constant leaves are
pruned into tiles after every slab) and are written once at the end.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from voxel.colour import srgb_to_linear
from voxel.grid import GridSpec
from voxel.openvdb_module import load_openvdb

GRID_NAMES = ("density", "layer", "color", "sdf")


def _xyz(array: NDArray[Any], dtype: type[np.floating[Any]]) -> NDArray[Any]:
    """Return a C-contiguous copy in OpenVDB's ``[i][j][k] = (x, y, z)`` order."""
    axes = (2, 1, 0, 3) if array.ndim == 4 else (2, 1, 0)
    return np.ascontiguousarray(array.transpose(axes), dtype=dtype)


def _content_box(mask: NDArray[np.bool_]) -> tuple[slice, slice, slice] | None:
    """Return the smallest ``(z, y, x)`` box holding every true voxel (None: none)."""
    spans = []
    for axis in range(3):
        hit = np.flatnonzero(mask.any(axis=tuple(a for a in range(3) if a != axis)))
        if len(hit) == 0:
            return None
        spans.append(slice(int(hit[0]), int(hit[-1]) + 1))
    return (spans[0], spans[1], spans[2])


class VdbStackWriter:
    """Accumulate slabs into OpenVDB grids and write them to one ``.vdb`` file.

    Parameters
    ----------
    grid : GridSpec
        The voxel grid (gives the transform).
    sdf_half_width_mm : float, mm
        Background value of the level set (its narrow-band half width).
    """

    def __init__(self, grid: GridSpec, *, sdf_half_width_mm: float) -> None:
        self._vdb = load_openvdb()
        vdb = self._vdb
        self.grid = grid
        transform = vdb.createLinearTransform()
        transform.scale(tuple(grid.voxel_mm))
        transform.translate(tuple(grid.origin_mm))
        self.density = vdb.FloatGrid(0.0)
        self.layer = vdb.FloatGrid(0.0)
        self.color = vdb.Vec3SGrid((0.0, 0.0, 0.0))
        self.sdf = vdb.FloatGrid(float(sdf_half_width_mm))
        self.sdf.gridClass = vdb.GridClass.LEVEL_SET
        self.color.vectorType = vdb.VectorType.INVARIANT
        for name, volume in zip(GRID_NAMES, self.grids, strict=True):
            volume.name = name
            volume.transform = transform
        self.density.gridClass = vdb.GridClass.FOG_VOLUME
        self._half_width = np.float32(sdf_half_width_mm)

    @property
    def grids(self) -> tuple[Any, Any, Any, Any]:
        """The grids ``density, layer, color, sdf``."""
        return (self.density, self.layer, self.color, self.sdf)

    def write_slab(
        self,
        z_start: int,
        layers: NDArray[np.uint8],
        rgb: NDArray[np.uint8],
        coloured: NDArray[np.bool_],
        sdf: NDArray[np.float32],
    ) -> None:
        """Copy one slab in.

        Parameters
        ----------
        z_start : int
            First row of the slab.
        layers : (Zs, Y, X) uint8
            Layer index; density is ``layers > 0``.
        rgb : (Zs, Y, X, 3) uint8
            sRGB colour, 0 outside the colour layers; stored as linear RGB.
        coloured : (Zs, Y, X) bool
            Voxels of the colour layers: active in ``color`` even where black.
        sdf : (Zs, Y, X) float32, mm
            Signed distance, equal to the half width outside the narrow band.
        """
        # Only the box holding non-background voxels is copied (every grid's background
        # is what lies outside the model and its narrow band).
        box = _content_box((layers > 0) | (sdf < self._half_width))
        if box is None:
            return
        layers, sdf, coloured = layers[box], sdf[box], coloured[box]
        linear_rgb = srgb_to_linear(rgb[box])
        # black colour voxels stay active in the sparse grid (its background is 0)
        linear_rgb[coloured] = np.maximum(linear_rgb[coloured], np.float32(1e-7))
        corner = (box[2].start, box[1].start, int(z_start) + box[0].start)
        self.density.copyFromArray(_xyz(layers > 0, np.float32), ijk=corner, tolerance=0.0)
        self.layer.copyFromArray(_xyz(layers, np.float32), ijk=corner, tolerance=0.0)
        self.color.copyFromArray(
            _xyz(linear_rgb, np.float32), ijk=corner, tolerance=(0.0, 0.0, 0.0)
        )
        self.sdf.copyFromArray(_xyz(sdf, np.float32), ijk=corner, tolerance=0.0)
        for volume in (self.density, self.layer, self.sdf):
            volume.prune(0.0)
        self.color.prune((0.0, 0.0, 0.0))

    def write(self, path: Path, metadata: dict[str, str] | None = None) -> dict[str, Any]:
        """Flood-fill the level set's sign, write all grids; return their summary.

        Returns
        -------
        dict
            Per grid name: ``class``, ``value_type``, ``active_voxels``, ``voxel_size_mm``.
        """
        self.sdf.signedFloodFill()
        for volume in self.grids:
            for key, value in (metadata or {}).items():
                volume[key] = value
        self._vdb.write(str(path), grids=list(self.grids))
        return describe_grids(self.grids)


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
