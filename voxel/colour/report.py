"""Predicted printed colour at surface samples, from the halftoned material voxels.

The optical model (an assumption, documented, not a measurement): light that enters the
part at a surface point and comes back has seen the materials under it along the inward
normal, those at depth ``s`` weighted by ``exp(-s / L)`` (a single-scattering,
exponentially attenuated contribution; ``L`` the optical depth, mm). The predicted colour
of the point is the weighted mean, in linear light, of the display colours of the material
voxels the inward rays pass (void voxels, outside the part, carry no weight), down to
``4 L`` (98 % of the weight). Light also spreads sideways about as far as it goes down,
so the rays start on a disc of radius ``L`` around the point (a golden-angle spiral of
`lateral_rays` points in the tangent plane): the halftone's grain is averaged as the
eye sees it, not read one voxel column at a time. With that model a thin colour layer
lets the white backing show through and a deep one does not: exactly the effect the
colour-adaptive thickness is meant to control.

:class:`ColourReport` is fed slab by slab (:meth:`ColourReport.add_slab`), like the
writers, so it needs only the sample rays in memory, never the volume. The difference to
the target is CIEDE2000 (colour-science), overall and per colour region (the target
colours binned by CIELAB lightness and hue).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import colour
import numpy as np
from numpy.typing import NDArray

from voxel.colour.colour_at import ColourAt
from voxel.colour.srgb import codes_to_linear, linear_to_srgb, srgb_to_lab
from voxel.grid import GridSpec

#: CIELAB hue angles (degrees) where each named hue sector starts, for the colour regions
#: (sRGB red lies near 40, yellow near 103, green near 136, blue near 306 degrees).
_HUE_STARTS = (15.0, 50.0, 80.0, 115.0, 170.0, 235.0, 290.0, 320.0)
_HUES = ("magenta", "red", "orange", "yellow", "green", "cyan", "blue", "purple", "magenta")


@dataclass(frozen=True)
class SurfaceSamples:
    """Points on a surface with their outward normals and target colours.

    Attributes
    ----------
    points : (N, 3) float64, mm
        Positions ``(x, y, z)``.
    normals : (N, 3) float64
        Unit outward normals of the faces the points lie on.
    face_ids : (N,) int64
        Face of each point.
    target_rgba : (N, 4) uint8
        sRGB + alpha the surface asks for at each point.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    face_ids: NDArray[np.int64]
    target_rgba: NDArray[np.uint8]


#: Decimals of the report's CIEDE2000 statistics (see :func:`_stats`).
REPORT_DECIMALS = 6


def sample_surface(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    colour_at: ColourAt,
    count: int,
    *,
    seed: int = 0,
) -> SurfaceSamples:
    """Draw `count` points uniformly by area on a triangle mesh, with their colours.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Outward-oriented triangles.
    colour_at : ColourAt
        Colour of surface points.
    count : int
        Number of samples.
    seed : int
        Seed of the generator (the sample is reproducible).
    """
    rng = np.random.default_rng(seed)
    corners = vertices[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    doubled_area = np.linalg.norm(cross, axis=1)
    face_ids = rng.choice(len(faces), size=count, p=doubled_area / doubled_area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    bary = np.stack([1 - u - v, u, v], axis=1)
    points = np.einsum("nk,nkd->nd", bary, corners[face_ids])
    normals = cross[face_ids] / np.maximum(doubled_area[face_ids], 1e-300)[:, None]
    rgba = np.asarray(colour_at(face_ids.astype(np.int64), bary), dtype=np.uint8)
    return SurfaceSamples(points, normals, face_ids.astype(np.int64), rgba)


class ColourReport:
    """Accumulate the predicted colour of surface samples from material slabs.

    Parameters
    ----------
    samples : SurfaceSamples
        The surface points to predict.
    grid : GridSpec
        The voxel grid of the material slabs.
    display_srgb : (M, 3) uint8
        Display colour of each material index (index 0, void, is never counted).
    optical_depth_mm : float, mm
        ``L`` of the optical model (see the module docstring).
    """

    def __init__(
        self,
        samples: SurfaceSamples,
        grid: GridSpec,
        display_srgb: NDArray[np.uint8],
        *,
        optical_depth_mm: float = 0.25,
        lateral_rays: int = 8,
    ) -> None:
        if not optical_depth_mm > 0 or lateral_rays < 1:
            raise ValueError(
                "optical_depth_mm must be > 0 and lateral_rays >= 1, got "
                f"{optical_depth_mm} and {lateral_rays}"
            )
        self.samples = samples
        self.grid = grid
        self.optical_depth_mm = float(optical_depth_mm)
        self.lateral_rays = int(lateral_rays)
        self._display_linear = codes_to_linear(np.asarray(display_srgb, np.uint8)).astype(
            np.float64
        )
        step = min(grid.voxel_mm)
        depths = (np.arange(int(np.ceil(4 * optical_depth_mm / step))) + 0.5) * step
        n, k = len(samples.points), len(depths)
        starts = samples.points[:, None, :] + tangent_disc(
            samples.normals, optical_depth_mm, lateral_rays
        )
        # The voxel of each ray's step (sample, ray, depth), one axis at a time: the nearest
        # centre, as ``np.rint(grid.world_to_index(point))`` gives it.
        valid = np.ones((n, lateral_rays, k), dtype=bool)
        index_zyx = []
        for axis, size in zip((2, 1, 0), grid.shape_zyx, strict=True):
            along = starts[:, :, None, axis] - samples.normals[:, None, None, axis] * depths
            along -= grid.origin_mm[axis]
            along /= grid.voxel_mm[axis]
            index = np.rint(along).astype(np.int64)
            valid &= (index >= 0) & (index < size)
            index_zyx.append(index)
        del along
        z = index_zyx[0][valid]
        # Rows in z order (stable: the order within a row stays): a radix sort of 16 bits.
        key = z.astype(np.uint16) if grid.shape_zyx[0] <= 1 << 16 else z
        order = np.argsort(key, kind="stable")
        self._z = z[order].astype(np.int32)
        self._yx = (index_zyx[1][valid] * grid.shape_zyx[2] + index_zyx[2][valid])[order]
        weight = np.broadcast_to(
            np.exp(-depths / optical_depth_mm).astype(np.float32), (n, lateral_rays, k)
        )
        self._weight = weight[valid][order]
        sample = np.broadcast_to(np.arange(n, dtype=np.int32)[:, None, None], valid.shape)
        self._sample = sample[valid][order]
        self._sums = np.zeros((n, 3))
        self._weights = np.zeros(n)
        self._slabs_seen = 0

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Take the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``."""
        lo, hi = np.searchsorted(self._z, [z_start, z_start + len(materials)])
        if hi == lo:
            return
        flat = (self._z[lo:hi] - z_start) * (materials.shape[1] * materials.shape[2])
        found = materials.reshape(-1)[flat + self._yx[lo:hi]]
        solid = found > 0
        who = self._sample[lo:hi][solid]
        weight = self._weight[lo:hi][solid]
        linear = self._display_linear[found[solid]]
        for channel in range(3):
            self._sums[:, channel] += np.bincount(
                who, weights=weight * linear[:, channel], minlength=len(self._weights)
            )
        self._weights += np.bincount(who, weights=weight, minlength=len(self._weights))

    def predicted_srgb(self) -> NDArray[np.float64]:
        """Return the predicted sRGB ``(N, 3)`` in ``[0, 1]`` (NaN where no voxel was seen)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            linear = self._sums / self._weights[:, None]
        return linear_to_srgb(linear)

    def result(self) -> dict[str, Any]:
        """Return CIEDE2000 statistics of predicted against target colour (JSON-ready)."""
        predicted = self.predicted_srgb()
        seen = np.isfinite(predicted).all(axis=1)
        target = self.samples.target_rgba[:, :3] / 255.0
        delta = np.full(len(target), np.nan)
        if seen.any():
            delta[seen] = delta_e_2000(predicted[seen], target[seen])
        regions = colour_regions(self.samples.target_rgba[:, :3])
        per_region = {}
        for name in sorted(set(regions[seen].tolist())):
            mask = seen & (regions == name)
            per_region[name] = {"samples": int(mask.sum()), **statistics(delta[mask])}
        return {
            "optical_model": (
                f"weights exp(-depth / {self.optical_depth_mm:g} mm) along the inward normal, "
                "linear-light mean of the materials' display colours"
            ),
            "samples": len(delta),
            "samples_seen": int(seen.sum()),
            "ciede2000": statistics(delta[seen]),
            "per_region": per_region,
        }


def tangent_disc(normals: NDArray[np.float64], radius: float, count: int) -> NDArray[np.float64]:
    """Return offsets ``(N, count, 3)`` on a disc of `radius` in each point's tangent plane.

    A golden-angle spiral (even density); one point is the centre when ``count == 1``.
    """
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    i = np.arange(count)
    r = radius * np.sqrt((i + 0.5) / count) if count > 1 else np.zeros(1)
    theta = i * np.pi * (3.0 - np.sqrt(5.0))
    a, b = r * np.cos(theta), r * np.sin(theta)
    offsets: NDArray[np.float64] = (
        a[None, :, None] * u[:, None, :] + b[None, :, None] * v[:, None, :]
    )
    return offsets


def delta_e_2000(srgb_a: NDArray[np.float64], srgb_b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return CIEDE2000 between sRGB colours ``(N, 3)`` in ``[0, 1]`` (D65)."""
    lab_a = srgb_to_lab(srgb_a)
    lab_b = srgb_to_lab(srgb_b)
    result: NDArray[np.float64] = np.asarray(colour.delta_E(lab_a, lab_b, method="CIE 2000"))
    return result


def colour_regions(srgb: NDArray[np.uint8]) -> NDArray[np.str_]:
    """Name the colour region of each sRGB ``(N, 3) uint8``: lightness and hue bins.

    ``"neutral light"`` etc. when CIELAB chroma is below 10; otherwise ``"dark red"``,
    ``"mid blue"``, ``"light yellow"``: L* in thirds and the hue angle in eight named
    sectors (:data:`_HUE_STARTS`).
    """
    lab = srgb_to_lab(np.asarray(srgb, np.float64) / 255.0)
    third = np.clip(lab[:, 0] // (100 / 3), 0, 2).astype(int)
    lightness = np.array(["dark", "mid", "light"])[third]
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    hue = np.degrees(np.arctan2(lab[:, 2], lab[:, 1])) % 360
    sector = np.array(_HUES)[np.searchsorted(_HUE_STARTS, hue, side="right")]
    names = np.where(chroma < 10, "neutral", sector)
    return np.char.add(np.char.add(lightness, " "), names)


def statistics(values: NDArray[np.float64]) -> dict[str, float | None]:
    """Mean, median, 95th percentile and maximum of `values` (None when empty).

    Rounded to :data:`REPORT_DECIMALS` (CIEDE2000 units; one unit is about a just
    noticeable difference): numpy's vectorised loops may round the last bits differently
    from run to run (memory alignment), and equal builds must write equal reports.
    """
    if len(values) == 0:
        return {"mean": None, "median": None, "p95": None, "max": None}
    return {
        "mean": round(math.fsum(values.tolist()) / len(values), REPORT_DECIMALS),
        "median": round(float(np.median(values)), REPORT_DECIMALS),
        "p95": round(float(np.percentile(values, 95)), REPORT_DECIMALS),
        "max": round(float(np.max(values)), REPORT_DECIMALS),
    }


def layer_model_srgb(
    ideal_linear: NDArray[np.float64],
    backing_linear: NDArray[np.float64],
    colour_depth_mm: NDArray[np.float64],
    optical_depth_mm: float,
) -> NDArray[np.float64]:
    """Return the optical model's colour of a colour layer over its backing, sRGB in [0, 1].

    A colour layer ``D`` deep whose mix has the linear colour `ideal_linear`, over an
    unbounded backing of `backing_linear`, under the model of this module (weights
    ``exp(-s / L)`` down to ``4 L``): the layer's share of the weight is
    ``(1 - exp(-D / L)) / (1 - exp(-4))`` (1 from ``D = 4 L`` on), the backing has the rest.

    Parameters
    ----------
    ideal_linear : (N, 3) float64
        Linear RGB of the colour layer's material mix.
    backing_linear : (3,) float64
        Linear RGB of the backing material.
    colour_depth_mm : (N,) float64, mm
        Depth of the colour layer under each point.
    optical_depth_mm : float, mm
        ``L``.
    """
    share = (1 - np.exp(-np.asarray(colour_depth_mm) / optical_depth_mm)) / (1 - np.exp(-4.0))
    share = np.clip(share, 0.0, 1.0)[:, None]
    linear = share * ideal_linear + (1 - share) * np.asarray(backing_linear)[None, :]
    return np.asarray(colour.cctf_encoding(np.clip(linear, 0, 1), "sRGB"), dtype=np.float64)


def thickness_effect(
    target_srgb: NDArray[np.uint8],
    ideal_linear: NDArray[np.float64],
    backing_linear: NDArray[np.float64],
    colour_depth_mm: NDArray[np.float64],
    constant_depth_mm: float,
    optical_depth_mm: float,
) -> dict[str, Any]:
    """Compare, under the optical model, the colour with per-face and constant depth.

    Returns CIEDE2000 statistics against the target of: the separation's own mix
    (``gamut``: what no thickness can fix), the colour layer at its per-face depth
    (``adaptive``) and at one constant depth (``constant``, e.g. the per-face depths'
    area-weighted mean: the same colour material).
    """
    target = np.asarray(target_srgb, np.float64)[:, :3] / 255.0
    ideal = np.asarray(colour.cctf_encoding(np.clip(ideal_linear, 0, 1), "sRGB"), np.float64)
    adaptive = layer_model_srgb(ideal_linear, backing_linear, colour_depth_mm, optical_depth_mm)
    constant = layer_model_srgb(
        ideal_linear,
        backing_linear,
        np.full(len(target), constant_depth_mm),
        optical_depth_mm,
    )
    return {
        "constant_depth_mm": float(constant_depth_mm),
        "gamut": statistics(delta_e_2000(ideal, target)),
        "adaptive": statistics(delta_e_2000(adaptive, target)),
        "constant": statistics(delta_e_2000(constant, target)),
        "adaptive_vs_constant": statistics(delta_e_2000(adaptive, constant)),
    }
