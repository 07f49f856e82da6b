"""Printed colour predicted by the two-flux model from the halftoned material voxels.

For each surface sample the voxel column under it *as written* is read: rays start on a
disc around the point in its tangent plane (one per voxel column beneath it, see
:mod:`~shellvox.voxel.colour._column_kernel`) and step inward along the normal, one smallest
voxel size at a time. The disc is how far light spreads sideways under the sample
before it comes back out: the *lateral reach* of the sample's mix
(:func:`lateral_reach`), the two-flux attenuation length ``1 / sqrt(K (K + 2 S))`` in
the band the mix reflects most, within ``[0.25, 1.0]`` mm (:data:`REACH_LIMITS_MM`). A
white pastel spreads light a few tenths of a millimetre, a translucent yellow a
millimetre and more; a disc that small under a translucent mix would see the halftone's
grain that its light averages away.

Light enters where the surface is: on a curved surface (a rounded edge) the tangent
plane leaves the part, so where a disc's rim lies farther than :data:`FLAT_MM` from the
surface, its rays start on a quadric fitted to the surface under the disc and go in
along its normals (:func:`_surface_quadrics`).

The material voxels the rays pass are counted per depth bin (``bin_mm`` thick, to
``depth_mm``): each bin's material shares over the disc are one layer's mix (Duncan),
the layers are stacked from the bottom up (the deepest bin's mix continued infinitely
deep beneath them) and seen through the surface (Saunderson), all under the printer's
:class:`~optics.Optics`. Void voxels (outside the part) do not count; a bin without
material voxels adds no layer.

:class:`ModelReport` is fed slab by slab, as the writers are, and keeps only the discs
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

from shellvox.voxel.colour._column_kernel import Discs, count_slab, lattice_spacing
from shellvox.voxel.colour._kubelka_munk import (
    Layer,
    layer,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
)
from shellvox.voxel.colour._optics import Optics
from shellvox.voxel.colour._report import statistics, tangent_basis
from shellvox.voxel.geometry import SurfaceIndex, nearest_on_surface
from shellvox.voxel.grid import GridSpec

#: A disc whose rim lies within this of the surface (mm) is flat enough for its rays to
#: start in the tangent plane (a quarter of the default depth bin).
FLAT_MM = 0.025

#: Points on the rim of a disc tested against :data:`FLAT_MM`.
RIM_POINTS = 8

#: Smallest and largest lateral reach (mm): at least a few voxels of the finest printer
#: grid across, at most half the depth the columns are read (light that spreads farther
#: has gone deeper than that).
REACH_LIMITS_MM = (0.25, 1.0)

#: Samples whose stacks :meth:`ModelReport.predicted_lab` evaluates at once.
PREDICT_CHUNK = 512


def lateral_reach(
    k: ArrayLike, s: ArrayLike, limits_mm: tuple[float, float] = REACH_LIMITS_MM
) -> NDArray[np.float64]:
    """Return how far light spreads sideways in mixes ``(N,)`` mm (see the module).

    Parameters
    ----------
    k, s : (N, B) float, 1/mm
        Absorption and scattering of each mix per band.
    limits_mm : (float, float), mm
        The reach is clipped to these.

    Examples
    --------
    >>> float(lateral_reach([[0.5]], [[0.75]], (0.0, 9.0))[0])  # 1 / sqrt(0.5 * 2)
    1.0
    """
    k, s = np.asarray(k, np.float64), np.asarray(s, np.float64)
    band = np.argmax(r_infinity(k, s), axis=1)
    rows = np.arange(len(k))
    kb, sb = k[rows, band], s[rows, band]
    rate = np.sqrt(kb * (kb + 2.0 * sb))
    length = np.divide(1.0, rate, out=np.full(len(k), np.inf), where=rate > 0)
    clipped: NDArray[np.float64] = np.clip(length, *limits_mm)
    return clipped


def _surface_quadrics(
    surface: SurfaceIndex,
    points: NDArray[np.float64],
    frame: NDArray[np.float64],
    radius_mm: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Return each disc's quadric height field ``(N, 5)`` mm (see :class:`Discs`).

    The surface's height below each tangent plane, measured at :data:`RIM_POINTS` points
    of the disc's rim (their nearest surface points), fitted by least squares; 0 where
    the rim lies within :data:`FLAT_MM` of the surface.
    """
    angle = 2.0 * np.pi * np.arange(RIM_POINTS) / RIM_POINTS
    ca, sa = np.cos(angle), np.sin(angle)
    u, v, n = frame[:, 1], frame[:, 2], frame[:, 3]
    rim = points[:, None, :] + radius_mm[:, None, None] * (
        ca[None, :, None] * u[:, None, :] + sa[None, :, None] * v[:, None, :]
    )
    hit = nearest_on_surface(surface, rim.reshape(-1, 3))
    corners = surface.vertices[surface.faces[hit.face_ids]]
    on = np.einsum("nc,nck->nk", hit.barycentric, corners).reshape(rim.shape)
    height = np.einsum("nrk,nk->nr", rim - on, n)  # (N, RIM): the rim above the surface
    design = np.stack([ca**2, ca * sa, sa**2, ca, sa], axis=1)  # (RIM, 5)
    quadric = np.linalg.lstsq(design, height.T, rcond=None)[0].T
    quadric[np.abs(height).max(axis=1) <= FLAT_MM] = 0.0
    return np.ascontiguousarray(quadric)


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
    disc_radius_mm : float or (N,) float, mm
        Radius of each sample's disc in the tangent plane (:func:`lateral_reach`).
    surface : SurfaceIndex, optional
        The surface the samples lie on: rays of discs that leave it start on it (see the
        module). Without it every ray starts in the tangent plane.
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
        disc_radius_mm: ArrayLike = 0.25,
        surface: SurfaceIndex | None = None,
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
        radius = np.ascontiguousarray(
            np.broadcast_to(np.asarray(disc_radius_mm, np.float64), (len(p),))
        )
        u, v = tangent_basis(n)
        frame = np.ascontiguousarray(np.stack([p, u, v, n], axis=1))
        quadric = (
            np.zeros((len(p), 5))
            if surface is None
            else _surface_quadrics(surface, p, frame, radius)
        )
        grid_values = np.array([*grid.origin_mm, *grid.voxel_mm], np.float64)
        walk = np.array([self.step_mm, self.n_steps, self.bin_mm], np.float64)
        spacing = lattice_spacing(frame[:, 1:3], radius, np.asarray(grid.voxel_mm))
        self._discs = Discs(frame, radius, spacing, quadric, grid_values, walk)
        self._counts = np.zeros((len(p), self.n_bins, self.n_materials), np.int32)

    @property
    def counts(self) -> NDArray[np.int32]:
        """Voxels counted ``(N, bins, M + 1)`` per sample, depth bin and material index.

        int32: a bin of a disc reads at most ``MAX_RAYS`` rays times a few steps.
        """
        return self._counts

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Count the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``."""
        count_slab(self._discs, int(z_start), np.ascontiguousarray(materials), self._counts)

    def predicted_lab(self) -> NDArray[np.float64]:
        """CIELAB ``(N, 3)`` of every sample (NaN where no material voxel was seen).

        Computed :data:`PREDICT_CHUNK` samples at a time: the stack's spectra are
        ``(samples, bins, bands)`` arrays, a few MB per chunk instead of a GB at once.
        """
        seen = observer(self.optics.wavelengths_nm)
        lab = np.full((self.n_samples, 3), np.nan)
        for start in range(0, self.n_samples, PREDICT_CHUNK):
            chunk = self._counts[start : start + PREDICT_CHUNK, :, 1:]
            reflectance, has = self._stack_reflectance(chunk)
            k1, k2 = self.optics.k1, self.optics.k2
            lab[start : start + len(chunk)] = reflectance_to_lab(
                saunderson(reflectance, k1, k2), seen
            )
            lab[start : start + len(chunk)][~has] = np.nan
        return lab

    def _stack_reflectance(
        self, counts: NDArray[np.int32]
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Return the stacks' reflectance ``(n, B)`` under their surface, and which saw any.

        `counts` ``(n, bins, M)`` are the material voxels per depth bin (void left out).
        """
        counts = counts.astype(np.float64)
        total = counts.sum(-1, keepdims=True)
        shares = np.divide(counts, total, out=np.zeros_like(counts), where=total > 0)
        k = shares @ self.optics.k_per_mm  # (n, bins, B)
        s = shares @ self.optics.s_per_mm
        has = total[..., 0] > 0  # (n, bins)
        deepest = np.where(has.any(1), self.n_bins - 1 - np.argmax(has[:, ::-1], axis=1), 0)
        rows = np.arange(len(counts))
        reflectance = r_infinity(k[rows, deepest], s[rows, deepest])
        layers = layer(k, s, np.where(has, self.bin_mm, 0.0))
        for b in range(self.n_bins - 1, -1, -1):  # bottom up
            reflectance = over(
                Layer(layers.reflectance[:, b], layers.transmittance[:, b]), reflectance
            )
        return reflectance, has.any(1)

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
        seen: NDArray[np.bool_] = np.all(np.isfinite(predicted), axis=1)
        total = np.full(len(aimed), np.nan)
        reproduction = np.full(len(aimed), np.nan)
        total[seen] = colour.delta_E(predicted[seen], target[seen], method="CIE 2000")
        reproduction[seen] = colour.delta_E(predicted[seen], aimed[seen], method="CIE 2000")
        gamut = np.asarray(colour.delta_E(aimed, target, method="CIE 2000"), np.float64)
        return ColumnErrors(seen, total, gamut, reproduction, predicted)


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
    predicted_lab : (N, 3) float64
        The prediction, CIELAB (NaN where not seen).
    """

    seen: NDArray[np.bool_]
    total: NDArray[np.float64]
    gamut: NDArray[np.float64]
    reproduction: NDArray[np.float64]
    predicted_lab: NDArray[np.float64]


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
        "reproduction_inside_colour_regions": statistics(errors.reproduction[seen & inner]),
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
