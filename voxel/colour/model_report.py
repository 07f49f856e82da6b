"""Printed colour predicted by the two-flux model from the halftoned material voxels.

For each surface sample the voxel column under it *as written* is read: rays start on a
disc of ``disc_radius_mm`` around the point in its tangent plane (light spreads sideways
about as far as it goes down) and step inward along the normal, one smallest voxel size
at a time. The material voxels they pass are counted per depth bin (``bin_mm`` thick, to
``depth_mm``): each bin's material shares over the disc are one layer's mix (Duncan), the
layers are stacked from the bottom up (the deepest bin's mix continued infinitely deep
beneath them) and seen through the surface (Saunderson), all under the printer's
:class:`~optics.Optics`. Void voxels (outside the part) do not count; a bin without
material voxels adds no layer.

:class:`ModelReport` is fed slab by slab, as the writers are, and keeps only the rays
and the counts ``(N, bins, M)``. Its result separates the errors: the *gamut* error
(target against the colour the separation aimed at, what no printing can reach) and the
*reproduction* error (that aim against the prediction from the voxels: halftone, voxels
and depth), reported for in-gamut targets apart.
"""

from __future__ import annotations

from typing import Any

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

from voxel.colour.kubelka_munk import (
    Layer,
    layer,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
)
from voxel.colour.optics import Optics
from voxel.colour.report import statistics, tangent_disc
from voxel.grid import GridSpec


class ModelReport:
    """Accumulate material voxels under surface samples and predict their colour.

    Parameters
    ----------
    points, normals : (N, 3) float64
        Sample positions (mm) and unit outward normals.
    grid : GridSpec
        The grid of the material slabs.
    optics : Optics
        Row ``i`` is material index ``i + 1`` of the slabs (index 0 is void).
    depth_mm : float, mm
        How deep the columns are read.
    bin_mm : float, mm
        Thickness of one layer of the stack.
    disc_radius_mm : float, mm
        Radius of the rays' disc in the tangent plane.
    lateral_rays : int
        Rays on the disc.
    neighbourhood_mm : float, mm
        Each ray step counts the voxels within this width in x and y around it.
    """

    def __init__(
        self,
        points: ArrayLike,
        normals: ArrayLike,
        grid: GridSpec,
        optics: Optics,
        *,
        depth_mm: float = 3.0,
        bin_mm: float = 0.05,
        disc_radius_mm: float = 0.25,
        lateral_rays: int = 16,
        neighbourhood_mm: float = 0.25,
    ) -> None:
        p = np.asarray(points, np.float64)
        n = np.asarray(normals, np.float64)
        origin, voxel = np.asarray(grid.origin_mm, np.float64), np.asarray(grid.voxel_mm)
        shape_zyx = grid.shape_zyx
        self.optics = optics
        self.n_samples = len(p)
        self.n_bins = int(np.ceil(depth_mm / bin_mm))
        self.bin_mm = float(bin_mm)
        self.n_materials = len(optics.names) + 1
        step = float(voxel.min())
        depths = (np.arange(int(np.ceil(depth_mm / step))) + 0.5) * step
        starts = p[:, None, :] + tangent_disc(n, disc_radius_mm, lateral_rays)
        valid = np.ones((len(p), lateral_rays, len(depths)), dtype=bool)
        index = []
        for axis, size in zip((2, 1, 0), shape_zyx, strict=True):
            along = starts[:, :, None, axis] - n[:, None, None, axis] * depths
            i = np.rint((along - origin[axis]) / voxel[axis]).astype(np.int64)
            valid &= (i >= 0) & (i < size)
            index.append(i)
        z = index[0][valid]
        order = np.argsort(z, kind="stable")
        self._z = z[order]
        self._y = index[1][valid][order].astype(np.int32)
        self._x = index[2][valid][order].astype(np.int32)
        self.shape_zyx = tuple(int(v) for v in shape_zyx)
        # each ray step reads the voxels within neighbourhood_mm across in x and y
        reach = np.maximum(np.floor(0.5 * neighbourhood_mm / voxel[:2]), 0).astype(int)
        self._offsets = [
            (dy, dx)
            for dy in range(-reach[1], reach[1] + 1)
            for dx in range(-reach[0], reach[0] + 1)
        ]
        bins = np.minimum((depths / bin_mm).astype(np.int64), self.n_bins - 1)
        cell = np.arange(len(p))[:, None, None] * self.n_bins + bins[None, None, :]
        self._cell = np.broadcast_to(cell, valid.shape)[valid][order]
        self.counts = np.zeros(len(p) * self.n_bins * self.n_materials, np.float64)

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Count the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``."""
        lo, hi = np.searchsorted(self._z, [z_start, z_start + len(materials)])
        if hi == lo:
            return
        _, n_y, n_x = self.shape_zyx
        flat = (self._z[lo:hi] - z_start).astype(np.int64) * (n_y * n_x)
        y, x = self._y[lo:hi], self._x[lo:hi]
        base = self._cell[lo:hi] * self.n_materials
        volume = materials.reshape(-1)
        for dy, dx in self._offsets:  # loop over the neighbourhood's offsets
            yy = np.clip(y + dy, 0, n_y - 1).astype(np.int64)
            xx = np.clip(x + dx, 0, n_x - 1)
            found = volume[flat + yy * n_x + xx]
            self.counts += np.bincount(base + found, minlength=len(self.counts))

    def predicted_lab(self) -> NDArray[np.float64]:
        """CIELAB ``(N, 3)`` of every sample (NaN where no material voxel was seen)."""
        counts = self.counts.reshape(self.n_samples, self.n_bins, self.n_materials)[..., 1:]
        total = counts.sum(-1, keepdims=True)
        shares = np.divide(counts, total, out=np.zeros_like(counts), where=total > 0)
        k = shares @ self.optics.k_per_mm  # (N, bins, B)
        s = shares @ self.optics.s_per_mm
        has = total[..., 0] > 0  # (N, bins)
        deepest = np.where(has.any(1), self.n_bins - 1 - np.argmax(has[:, ::-1], axis=1), 0)
        rows = np.arange(self.n_samples)
        reflectance = r_infinity(k[rows, deepest], s[rows, deepest])
        layers = layer(k, s, np.where(has, self.bin_mm, 0.0))
        for b in range(self.n_bins - 1, -1, -1):  # bottom up
            reflectance = over(
                Layer(layers.reflectance[:, b], layers.transmittance[:, b]), reflectance
            )
        seen = observer(self.optics.wavelengths_nm)
        lab = reflectance_to_lab(saunderson(reflectance, self.optics.k1, self.optics.k2), seen)
        lab[~has.any(1)] = np.nan
        return lab

    def result(self, aimed_lab: ArrayLike, target_lab: ArrayLike, *, in_gamut_de: float = 1.0
               ) -> dict[str, Any]:  # fmt: skip
        """CIEDE2000 statistics: gamut (target vs aim) and reproduction (aim vs voxels)."""
        aimed, target = np.asarray(aimed_lab, np.float64), np.asarray(target_lab, np.float64)
        predicted = self.predicted_lab()
        seen = np.isfinite(predicted).all(1)
        gamut = np.asarray(colour.delta_E(aimed, target, method="CIE 2000"), np.float64)
        reproduction = np.full(len(aimed), np.nan)
        reproduction[seen] = colour.delta_E(predicted[seen], aimed[seen], method="CIE 2000")
        total = np.full(len(aimed), np.nan)
        total[seen] = colour.delta_E(predicted[seen], target[seen], method="CIE 2000")
        inside = seen & (gamut <= in_gamut_de)
        return {
            "samples": len(aimed),
            "samples_seen": int(seen.sum()),
            "in_gamut_samples": int(inside.sum()),
            "gamut": statistics(gamut),
            "reproduction": statistics(reproduction[seen]),
            "in_gamut_total": statistics(total[inside]),
            "total": statistics(total[seen]),
        }
