"""The voxel grid: index space ``(z, y, x)`` and world space ``(x, y, z)`` mm, kept apart.

Voxel ``(z, y, x)`` has its centre at ``origin_mm + (x * vx, y * vy, z * vz)``: ``origin_mm``
is the centre of voxel ``(0, 0, 0)`` (see :mod:`voxel`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

Vec3 = tuple[float, float, float]


class GridRangeError(ValueError):
    """The grid asked for has more voxels on a side than any index can count."""


@dataclass(frozen=True)
class GridSpec:
    """An axis-aligned grid of anisotropic voxels.

    Parameters
    ----------
    origin_mm : (3,) float, mm
        Centre ``(x, y, z)`` of voxel ``(0, 0, 0)``.
    voxel_mm : (3,) float, mm
        Voxel size ``(vx, vy, vz)``, all positive.
    shape_zyx : (3,) int
        Number of voxels ``(Z, Y, X)``.

    Examples
    --------
    >>> from shellvox import GridSpec
    >>> grid = GridSpec((0.0, 0.0, 0.0), (0.5, 1.0, 2.0), (2, 3, 4))
    >>> grid.index_to_world([[1, 2, 3]]).tolist()
    [[1.5, 2.0, 2.0]]
    """

    origin_mm: Vec3
    voxel_mm: Vec3
    shape_zyx: tuple[int, int, int]

    def __post_init__(self) -> None:
        if len(self.origin_mm) != 3 or not all(math.isfinite(v) for v in self.origin_mm):
            raise ValueError(f"origin_mm must be 3 finite numbers (x, y, z), got {self.origin_mm}")
        if len(self.voxel_mm) != 3 or not all(math.isfinite(v) and v > 0 for v in self.voxel_mm):
            raise ValueError(f"voxel_mm must be 3 positive numbers (x, y, z), got {self.voxel_mm}")
        if len(self.shape_zyx) != 3 or not all(int(n) >= 1 for n in self.shape_zyx):
            raise ValueError(f"shape_zyx must be 3 positive counts (Z, Y, X), got {self.shape_zyx}")

    @classmethod
    def from_bounds(
        cls, lower_mm: ArrayLike, upper_mm: ArrayLike, voxel_mm: ArrayLike, *, margin_mm: float
    ) -> GridSpec:
        """Return the grid covering a box plus a margin on every side.

        Parameters
        ----------
        lower_mm, upper_mm : (3,) float, mm
            Corners ``(x, y, z)`` of the box to cover.
        voxel_mm : (3,) float, mm
            Voxel size ``(vx, vy, vz)``.
        margin_mm : float, mm
            Free space kept around the box (at least one voxel is always kept).

        Returns
        -------
        GridSpec
            Voxel centres span at least ``[lower - margin, upper + margin]`` on each axis.

        Raises
        ------
        GridRangeError
            A side would have 2**62 voxels or more (or the sizes overflow).
        """
        lower = np.asarray(lower_mm, dtype=np.float64).reshape(3)
        upper = np.asarray(upper_mm, dtype=np.float64).reshape(3)
        size = np.asarray(voxel_mm, dtype=np.float64).reshape(3)
        if not np.all(upper >= lower):
            raise ValueError(f"upper_mm must be >= lower_mm, got {upper} and {lower}")
        if not np.all(size > 0):
            raise ValueError(f"voxel_mm must be positive, got {size}")
        if not margin_mm >= 0:
            raise ValueError(f"margin_mm must be >= 0, got {margin_mm}")
        pad = np.maximum(margin_mm, size)
        origin = lower - pad
        with np.errstate(over="ignore", invalid="ignore"):
            span = np.ceil((upper + pad - origin) / size) + 1
        if not np.all(span < 2.0**62):  # also inf and NaN: int64 would wrap round
            raise GridRangeError(
                f"the grid would have {span[0]:.3g} x {span[1]:.3g} x {span[2]:.3g} voxels "
                "(x, y, z), past any index range"
            )
        counts = span.astype(np.int64)
        return cls(
            (float(origin[0]), float(origin[1]), float(origin[2])),
            (float(size[0]), float(size[1]), float(size[2])),
            (int(counts[2]), int(counts[1]), int(counts[0])),
        )

    @property
    def n_voxels(self) -> int:
        """Total number of voxels."""
        return int(np.prod(self.shape_zyx, dtype=np.int64))

    def axis_mm(self, axis: str) -> NDArray[np.float64]:
        """Return the voxel centre coordinates along ``"x"``, ``"y"`` or ``"z"``, mm."""
        position = "xyz".find(axis)
        if position < 0 or len(axis) != 1:
            raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}")
        count = self.shape_zyx[2 - position]
        steps = np.arange(count, dtype=np.float64)
        return self.origin_mm[position] + self.voxel_mm[position] * steps

    def index_to_world(self, index_zyx: ArrayLike) -> NDArray[np.float64]:
        """Return centres ``(N, 3)`` ``(x, y, z)`` mm of indices ``(N, 3)`` ``(z, y, x)``."""
        index = np.asarray(index_zyx, dtype=np.float64)
        if index.ndim != 2 or index.shape[1] != 3:
            raise ValueError(f"index_zyx must be (N, 3), got shape {index.shape}")
        world: NDArray[np.float64] = np.asarray(self.origin_mm) + index[:, ::-1] * np.asarray(
            self.voxel_mm
        )
        return world

    def world_to_index(self, points_mm: ArrayLike) -> NDArray[np.float64]:
        """Return continuous indices ``(N, 3)`` ``(z, y, x)`` of points ``(N, 3)`` ``(x, y, z)`` mm.

        ``np.rint`` of the result is the voxel whose centre is nearest.
        """
        points = np.asarray(points_mm, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points_mm must be (N, 3), got shape {points.shape}")
        index: NDArray[np.float64] = (
            (points - np.asarray(self.origin_mm)) / np.asarray(self.voxel_mm)
        )[:, ::-1]
        return np.ascontiguousarray(index)

    def index_to_world_matrix(self) -> NDArray[np.float64]:
        """Return the 4x4 matrix taking column ``(x, y, z, 1)`` index coordinates to mm."""
        matrix = np.diag([*self.voxel_mm, 1.0])
        matrix[:3, 3] = self.origin_mm
        return matrix
