"""Surface samples for the colour report, and what its parts share.

:func:`sample_surface` draws points uniformly by area with their target colours;
:func:`tangent_basis` gives each point's tangent plane (the rays of the report's
discs lie in it); :func:`colour_regions` names the target colours'
regions (CIELAB lightness and hue bins) and :func:`statistics` condenses CIEDE2000
values for the manifest. The prediction from the voxels is
:class:`shellvox.voxel.colour._model_report.ModelReport`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._colour_at import ColourAt
from shellvox.voxel.colour._srgb import srgb_to_lab

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


def tangent_basis(
    normals: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return unit vectors ``u``, ``v`` ``(N, 3)`` spanning each tangent plane (``u x v = n``)."""
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(normals, u)


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
