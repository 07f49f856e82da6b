"""Depth below the surface of voxels, from the build's ``thickness.ply``.

A build keeps no per-voxel depth (the layers are thresholds of it, :mod:`shellvox.voxel.slab`),
so the viewer recomputes it where asked: the exact distance from voxel centres to the
model's surface, and the face whose point is nearest, by libigl's tree
(:mod:`shellvox.voxel.geometry._nearest`, the query the build itself uses beyond its scan). The
surface is ``thickness.ply`` (the build's mesh in its own millimetres, with each face's layer
thicknesses); a build made with ``--thickness`` has none, and then has no depth.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.output import read_face_ply
from shellvox.voxel._compiled import kernel
from shellvox.voxel.geometry import SurfaceIndex, nearest_faces
from shellvox.voxel.geometry._closest_point import triangle_d2


@dataclass(frozen=True, eq=False)
class Surface:
    """The model's surface with its per-face layer thicknesses.

    Parameters
    ----------
    index : SurfaceIndex
        The faces, ready for nearest-point queries.
    thickness_mm : (K, F) float64, mm
        Thickness of layer ``k + 1`` (outside in) on each face.
    colour_layer_mm : (F,) float64, mm
        Thickness of the colour layer(s) on each face (the ``thickness`` property).
    """

    index: SurfaceIndex
    thickness_mm: NDArray[np.float64]
    colour_layer_mm: NDArray[np.float64]

    @classmethod
    def load(cls, path: Path) -> Surface:
        """Read ``thickness.ply`` (raises ValueError when it is not that file)."""
        ply = read_face_ply(path)
        names = sorted(
            (name for name in ply.values if name.startswith("thickness_")),
            key=lambda name: int(name.removeprefix("thickness_") or 0),
        )
        if "thickness" not in ply.values or not names or not len(ply.faces):
            raise ValueError(f"{path}: no faces with thickness and thickness_1.. values")
        thickness = np.stack([ply.values[name] for name in names])
        index = SurfaceIndex.build(np.ascontiguousarray(ply.vertices), ply.faces)
        return cls(index, thickness, ply.values["thickness"])

    @property
    def n_layers(self) -> int:
        """``K``: the layers that have a thickness (the core has none)."""
        return int(self.thickness_mm.shape[0])

    def nearest(
        self, points_mm: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Return the distance to the surface and the nearest face of each point.

        Parameters
        ----------
        points_mm : (N, 3) float64, mm
            Query points ``(x, y, z)``.

        Returns
        -------
        depth_mm : (N,) float64, mm
            Unsigned distance to the surface.
        face_ids : (N,) int64
            The face of the nearest point (one of them at a tie).
        """
        if not len(points_mm):
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        face_ids, depth = nearest_faces(self.index, np.ascontiguousarray(points_mm, np.float64))
        return depth, face_ids

    def deciding_face(self, point_mm: NDArray[np.float64]) -> tuple[float, int]:
        """Return the distance to the surface and the face whose layers hold a point.

        The build gives a voxel the layers of its nearest face, the lowest index among
        faces at the same distance (:mod:`shellvox.voxel.geometry._distance_scan`); here "the same"
        allows a relative ``1e-9``, so a translated copy of the model (a tray) decides as
        the model alone.

        Parameters
        ----------
        point_mm : (3,) float64, mm
            The point ``(x, y, z)``.
        """
        corners = self.index.vertices[self.index.faces]  # (F, 3, 3)
        d2 = _squared_distances(np.ascontiguousarray(point_mm, np.float64), corners)
        nearest = float(d2.min())
        face = int(np.flatnonzero(d2 <= nearest * (1.0 + 1e-9) + 1e-18)[0])
        return float(np.sqrt(nearest)), face


@kernel
def _squared_distances(p: NDArray[np.float64], corners: NDArray[np.float64]) -> NDArray[np.float64]:
    """Exact squared distance ``(F,)`` from `p` to each triangle ``(F, 3, 3)``."""
    d2 = np.empty(corners.shape[0])
    for f in range(corners.shape[0]):
        a, b, c = corners[f, 0], corners[f, 1], corners[f, 2]
        d2[f] = triangle_d2(p[0], p[1], p[2], a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2])
    return d2
