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

from typing import Any, NamedTuple

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

from voxel.colour.column_kernel import Rays, count_slab
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
from voxel.colour.report import statistics, tangent_lattice
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
    ray_spacing_mm : float, mm, optional
        Spacing of the rays' square lattice on the disc (default: the smaller of the
        voxel's x and y sizes, so every voxel under the disc is read).
    """

    def __init__(
        self,
        points: ArrayLike,
        normals: ArrayLike,
        grid: GridSpec,
        optics: Optics,
        *,
        depth_mm: float = 2.0,
        bin_mm: float = 0.1,
        disc_radius_mm: float = 0.25,
        ray_spacing_mm: float | None = None,
    ) -> None:
        p = np.asarray(points, np.float64)
        n = np.asarray(normals, np.float64)
        self.optics = optics
        self.grid = grid
        self.n_samples = len(p)
        self.n_bins = int(np.ceil(depth_mm / bin_mm))
        self.bin_mm = float(bin_mm)
        self.n_materials = len(optics.names) + 1
        self.step_mm = float(min(grid.voxel_mm))
        self.n_steps = int(np.ceil(depth_mm / self.step_mm))
        spacing = min(grid.voxel_mm[:2]) if ray_spacing_mm is None else ray_spacing_mm
        offsets = tangent_lattice(n, disc_radius_mm, spacing)
        lateral_rays = offsets.shape[1]
        starts = p[:, None, :] + offsets
        grid_values = np.array([*grid.origin_mm, *grid.voxel_mm], np.float64)
        walk = np.array([self.step_mm, self.n_steps, self.bin_mm], np.float64)
        self._rays = Rays(
            np.ascontiguousarray(starts.reshape(-1, 3)),
            np.ascontiguousarray(np.repeat(-n, lateral_rays, axis=0)),
            np.repeat(np.arange(len(p), dtype=np.int64), lateral_rays),
            grid_values,
            walk,
        )
        self._counts = np.zeros((len(p), self.n_bins, self.n_materials), np.int64)

    @property
    def counts(self) -> NDArray[np.int64]:
        """Voxels counted ``(N, bins, M + 1)`` per sample, depth bin and material index."""
        return self._counts

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Count the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``."""
        count_slab(self._rays, int(z_start), np.ascontiguousarray(materials), self._counts)

    def predicted_lab(self) -> NDArray[np.float64]:
        """CIELAB ``(N, 3)`` of every sample (NaN where no material voxel was seen)."""
        counts = self._counts[..., 1:].astype(np.float64)
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

    def errors(self, aimed_lab: ArrayLike, target_lab: ArrayLike) -> ColumnErrors:
        """Return each sample's CIEDE2000 errors, apart (the prediction made once).

        Parameters
        ----------
        aimed_lab : (N, 3) float
            The colour the separation aims at for each sample (its mix, deep).
        target_lab : (N, 3) float
            The target colour of each sample.
        """
        aimed, target = np.asarray(aimed_lab, np.float64), np.asarray(target_lab, np.float64)
        predicted = self.predicted_lab()
        seen = np.isfinite(predicted).all(1)
        total = np.full(len(aimed), np.nan)
        reproduction = np.full(len(aimed), np.nan)
        total[seen] = colour.delta_E(predicted[seen], target[seen], method="CIE 2000")
        reproduction[seen] = colour.delta_E(predicted[seen], aimed[seen], method="CIE 2000")
        gamut = np.asarray(colour.delta_E(aimed, target, method="CIE 2000"), np.float64)
        return ColumnErrors(seen, total, gamut, reproduction)


class ColumnErrors(NamedTuple):
    """CIEDE2000 errors of the samples, apart (see the module).

    Attributes
    ----------
    seen : (N,) bool
        A material voxel was read under the sample.
    total : (N,) float64
        Prediction against target (NaN where not seen).
    gamut : (N,) float64
        The separation's aim against the target.
    reproduction : (N,) float64
        Prediction against the aim (NaN where not seen).
    """

    seen: NDArray[np.bool_]
    total: NDArray[np.float64]
    gamut: NDArray[np.float64]
    reproduction: NDArray[np.float64]


def summary(
    errors: ColumnErrors,
    interior: NDArray[np.bool_] | None = None,
    *,
    in_gamut_de: float = 1.0,
) -> dict[str, Any]:
    """Return the errors' statistics, JSON-ready.

    ``in_gamut`` is over the seen samples within `in_gamut_de` of the gamut that lie in
    the `interior` of a colour region (all of them when None); ``in_gamut_all`` includes
    the others, also given apart as ``near_colour_edges``.
    """
    seen, total = errors.seen, errors.total
    inner = np.ones(len(seen), bool) if interior is None else np.asarray(interior, bool)
    inside = seen & (errors.gamut <= in_gamut_de)
    return {
        "model": "kubelka-munk voxel columns",
        "samples": len(seen),
        "samples_seen": int(seen.sum()),
        "gamut": statistics(errors.gamut),
        "reproduction": statistics(errors.reproduction[seen]),
        "ciede2000": statistics(total[seen]),
        "in_gamut_all_samples": int(inside.sum()),
        "in_gamut_all": statistics(total[inside]),
        "in_gamut_samples": int((inside & inner).sum()),
        "in_gamut": statistics(total[inside & inner]),
        "near_colour_edges": {
            "samples": int((seen & ~inner).sum()),
            "in_gamut": statistics(total[inside & ~inner]),
        },
    }
