"""Absorption and scattering of every material, fitted to a printed, measured chart.

A chart patch is a stack of layers, listed top first, each a mix of materials
(fractions) of some thickness, with nothing beneath the last one (reflectance 0); its
reading is spectral reflectance with the gloss included (d/8 SCI). Under the two-flux
model (:mod:`kubelka_munk`) the reading is a function of every material's ``K`` and
``S`` per band. :func:`fit_optics` finds them by bounded non-linear least squares
(scipy's trust-region reflective ``least_squares``) in ``log K`` and ``log S``, with a
penalty on their second differences along the wavelength (the spectra stay smooth), from
a start (the profile's optics, measured or assumed). Each band's readings depend only on
that band's parameters, which the solver is told (a sparse Jacobian).

:func:`cross_validate` refits with each of ``folds`` groups of patches held out and
reports the CIEDE2000 of the held-out patches' predictions: how well the fitted model
predicts stacks it has not seen.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from shellvox.voxel.colour._kubelka_munk import (
    layer,
    observer,
    over,
    reflectance_to_lab,
    saunderson,
)
from shellvox.voxel.colour._optics import Optics

#: Weight of the second-difference penalty on log K and log S (per band step).
SMOOTHNESS = 0.05

#: Bounds of log K and log S (1/mm): 6e-6 .. 3000.
LOG_BOUNDS = (-12.0, 8.0)


@dataclass(frozen=True)
class Patch:
    """One chart patch.

    Parameters
    ----------
    patch_id : str
    fractions : (L, M) float64
        Share of each material in each layer, top first (rows sum to 1).
    thickness_mm : (L,) float64, mm
    """

    patch_id: str
    fractions: NDArray[np.float64]
    thickness_mm: NDArray[np.float64]


def predict(optics: Optics, patches: list[Patch]) -> NDArray[np.float64]:
    """Return the readings ``(N, B)`` (gloss included) of `patches` under `optics`."""
    return _predict(optics.k_per_mm, optics.s_per_mm, optics, patches)


def _predict(
    k: NDArray[np.float64], s: NDArray[np.float64], optics: Optics, patches: list[Patch]
) -> NDArray[np.float64]:
    out = np.empty((len(patches), k.shape[1]))
    for i, patch in enumerate(patches):  # loop over patches (tens), layers vectorised
        layers = layer(patch.fractions @ k, patch.fractions @ s, patch.thickness_mm)
        reflectance = np.zeros(k.shape[1])
        for r, t in zip(layers.reflectance[::-1], layers.transmittance[::-1], strict=True):
            reflectance = over(type(layers)(r, t), reflectance)
        out[i] = reflectance
    return saunderson(out, optics.k1, optics.k2)


def fit_optics(
    start: Optics, patches: list[Patch], measured: ArrayLike, *, smoothness: float = SMOOTHNESS
) -> tuple[Optics, NDArray[np.float64]]:
    """Fit every material's K and S per band to the readings of `patches`.

    Parameters
    ----------
    start : Optics
        Starting values, bands and surface (k1, k2 are kept).
    patches : list of Patch
    measured : (N, B) float
        Each patch's reading at ``start.wavelengths_nm``.
    smoothness : float
        Weight of the second-difference penalty along the wavelength.

    Returns
    -------
    optics : Optics
        The fitted parameters (``assumed`` False).
    residual : (N, B) float64
        Prediction minus reading.
    """
    reading = np.asarray(measured, np.float64)
    m, b = start.k_per_mm.shape
    x0 = np.concatenate(
        [
            np.log(np.clip(start.k_per_mm, 1e-5, None)).ravel(),
            np.log(np.clip(start.s_per_mm, 1e-5, None)).ravel(),
        ]
    )
    x0 = np.clip(x0, *LOG_BOUNDS)

    def unpack(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return np.exp(x[: m * b]).reshape(m, b), np.exp(x[m * b :]).reshape(m, b)

    def residuals(x: NDArray[np.float64]) -> NDArray[np.float64]:
        k, s = unpack(x)
        data = (_predict(k, s, start, patches) - reading).ravel()
        curves = x.reshape(2 * m, b)
        rough = smoothness * (curves[:, 2:] - 2 * curves[:, 1:-1] + curves[:, :-2]).ravel()
        return np.concatenate([data, rough])

    solution = least_squares(
        residuals,
        x0,
        bounds=LOG_BOUNDS,
        jac_sparsity=_sparsity(len(patches), m, b),
        x_scale="jac",
        xtol=1e-10,
        ftol=1e-12,
        max_nfev=200,
    )
    k, s = unpack(solution.x)
    fitted = replace(start, k_per_mm=k, s_per_mm=s, assumed=False)
    return fitted, predict(fitted, patches) - reading


def _sparsity(n: int, m: int, b: int) -> lil_matrix:
    """Which parameters (log K, log S per material and band) each residual depends on."""
    rows = n * b + 2 * m * (b - 2)
    pattern = lil_matrix((rows, 2 * m * b), dtype=np.int8)
    for band in range(b):  # loop over bands: readings of a band need its parameters only
        columns = [c * b + band for c in range(2 * m)]
        for patch in range(n):
            pattern[patch * b + band, columns] = 1
    for curve in range(2 * m):  # the penalty: three neighbouring bands of one curve
        for j in range(b - 2):
            pattern[n * b + curve * (b - 2) + j, [curve * b + j + d for d in range(3)]] = 1
    return pattern


def delta_e_of_readings(optics: Optics, a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """CIEDE2000 between two sets of readings ``(N, B)`` under D50."""
    seen = observer(optics.wavelengths_nm)
    lab_a = reflectance_to_lab(np.asarray(a, np.float64), seen)
    lab_b = reflectance_to_lab(np.asarray(b, np.float64), seen)
    return np.asarray(colour.delta_E(lab_a, lab_b, method="CIE 2000"), np.float64)


def cross_validate(
    start: Optics, patches: list[Patch], measured: ArrayLike, *, folds: int = 5, seed: int = 0
) -> dict[str, Any]:
    """CIEDE2000 of held-out patches, each fold fitted without them."""
    reading = np.asarray(measured, np.float64)
    order = np.random.default_rng(seed).permutation(len(patches))
    errors = np.empty(len(patches))
    for fold in range(folds):  # loop over folds
        held = order[fold::folds]
        kept = np.setdiff1d(order, held)
        fitted, _ = fit_optics(start, [patches[i] for i in kept], reading[kept])
        held_patches = [patches[i] for i in held]
        errors[held] = delta_e_of_readings(fitted, predict(fitted, held_patches), reading[held])
    return {
        "folds": folds,
        "median": float(np.median(errors)),
        "p95": float(np.percentile(errors, 95)),
        "max": float(errors.max()),
    }


#: Thicknesses (mm) of the chart's single-material patches, and the depth taken as deep.
CHART_THICKNESS_MM = (0.1, 0.25, 0.5, 1.0)
DEEP_MM = 3.0
#: Shares of each material mixed into white, and into clear, on the chart.
CHART_MIX_SHARES = (0.05, 0.2)


def chart_patches(roles: tuple[str, ...]) -> list[Patch]:
    """Patches that identify every material's K and S (see the module).

    Each material alone, deep, and at :data:`CHART_THICKNESS_MM` over deep white and over
    deep black; each colourant mixed into white and into clear at
    :data:`CHART_MIX_SHARES`, deep and 0.5 mm over black. Needs a white and a black role.
    """
    m = len(roles)
    white, black = roles.index("white"), roles.index("black")
    eye = np.eye(m)
    patches: list[Patch] = []

    def add(name: str, layers: list[tuple[NDArray[np.float64], float]]) -> None:
        fractions = np.array([f for f, _ in layers])
        thickness = np.array([t for _, t in layers])
        patches.append(Patch(f"P{len(patches) + 1:03d}-{name}", fractions, thickness))

    for i, role in enumerate(roles):
        add(f"{role}-deep", [(eye[i], DEEP_MM)])
        for t in CHART_THICKNESS_MM:
            for base, base_name in ((white, "white"), (black, "black")):
                if base != i:
                    add(f"{role}-{t:g}mm-over-{base_name}", [(eye[i], t), (eye[base], DEEP_MM)])
    for i, role in enumerate(roles):
        for carrier in (white, roles.index("clear")) if "clear" in roles else (white,):
            if carrier == i or roles[i] in ("white", "clear"):
                continue
            for share in CHART_MIX_SHARES:
                mix = share * eye[i] + (1 - share) * eye[carrier]
                name = f"{role}-{share:g}-in-{roles[carrier]}"
                add(f"{name}-deep", [(mix, DEEP_MM)])
                add(f"{name}-0.5mm-over-black", [(mix, 0.5), (eye[black], DEEP_MM)])
    return patches
