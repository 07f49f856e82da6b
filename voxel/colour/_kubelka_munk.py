r"""Two-flux (Kubelka-Munk) reflectance of stacked, scattering colour layers.

A layer of thickness ``t`` (mm) of a material with absorption ``K`` and scattering ``S``
(1/mm, one value per wavelength band) reflects ``R`` and transmits ``T`` of a diffuse
flux, from Kubelka's hyperbolic solution of the two-flux equations

.. math::

    di/dz = -(K + S)\,i + S\,j, \qquad dj/dz = (K + S)\,j - S\,i,

written here with the effective attenuation :math:`q = \sqrt{K (K + 2 S)}` and the
factor :math:`e^{-q t}` taken out of numerator and denominator:

.. math::

    D = (S + K)\,u + c, \quad R = S\,u / D, \quad T = e^{-q t} / D, \quad
    u = t\,\frac{1 - e^{-2 q t}}{2 q t}, \quad c = \frac{1 + e^{-2 q t}}{2},

finite for every ``K, S >= 0`` and every ``t >= 0`` (``S = 0`` gives ``R = 0``,
``T = exp(-K t)``; ``K = 0`` gives ``R = S t / (1 + S t)``; ``t -> inf`` gives
:math:`R_\infty = 1 + K/S - \sqrt{(K/S)^2 + 2 K/S}`). Layers are added from the bottom
up, ``R = R_1 + T_1^2 R_b / (1 - R_1 R_b)``; mixtures take the fraction-weighted sums of
their components' ``K`` and ``S`` (Duncan); the air-resin surface follows Saunderson,
specular included, ``R_m = k_1 + (1 - k_1)(1 - k_2) R / (1 - k_2 R)``.

The colorimetry is colour-science's: spectral reflectance to CIE XYZ under D50 with the
CIE 1931 2 degree observer (summed at the model's bands), then CIELAB (D50 white).

References
----------
Kubelka, P. (1948). New contributions to the optics of intensely light-scattering
materials, part I. JOSA 38(5), 448-457. Duncan, D. R. (1940). Proc. Phys. Soc. 52, 390.
Saunderson, J. L. (1942). JOSA 32(12), 727-736.
"""

from __future__ import annotations

from typing import NamedTuple

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Saunderson's external and internal surface reflectance for a resin of n about 1.5
#: (k1 = ((n - 1) / (n + 1))^2; k2 the textbook value for diffuse light inside).
K1_DEFAULT = 0.04
K2_DEFAULT = 0.6

#: The model's default wavelength bands, nm.
WAVELENGTHS_NM = np.arange(400.0, 701.0, 10.0)


class Layer(NamedTuple):
    """Diffuse reflectance and transmittance of one layer, per band.

    Attributes
    ----------
    reflectance : (..., B) float64, [0, 1]
    transmittance : (..., B) float64, [0, 1]
    """

    reflectance: NDArray[np.float64]
    transmittance: NDArray[np.float64]


def mix(fractions: ArrayLike, per_material: ArrayLike) -> NDArray[np.float64]:
    """Absorption or scattering of mixtures: the fraction-weighted sum (Duncan).

    Parameters
    ----------
    fractions : (..., M) float
        Share of each of ``M`` materials (rows summing to 1).
    per_material : (M, B) float, 1/mm
        ``K`` or ``S`` of each material per band.

    Returns
    -------
    (..., B) float64, 1/mm

    Examples
    --------
    >>> mix([0.25, 0.75], [[4.0, 0.0], [0.0, 8.0]]).tolist()
    [1.0, 6.0]
    """
    return np.asarray(fractions, np.float64) @ np.asarray(per_material, np.float64)


def layer(k: ArrayLike, s: ArrayLike, thickness_mm: ArrayLike) -> Layer:
    """Reflectance and transmittance of a layer (no surface), Kubelka's solution.

    Parameters
    ----------
    k, s : (..., B) float, 1/mm
        Absorption and scattering, ``>= 0``; broadcast with each other.
    thickness_mm : (...) or (..., B) float, mm
        Layer thickness, ``>= 0`` (``inf`` allowed: the layer's ``R_inf``).

    Returns
    -------
    Layer

    Examples
    --------
    >>> r, t = layer([0.0], [1.0], 1.0)  # K = 0: R = S t / (1 + S t)
    >>> float(r[0]), float(t[0])
    (0.5, 0.5)
    """
    k, s = np.broadcast_arrays(np.asarray(k, np.float64), np.asarray(s, np.float64))
    t = np.asarray(thickness_mm, np.float64)
    if t.ndim < k.ndim:
        t = t[..., None]
    if (k < 0).any() or (s < 0).any() or (t < 0).any():
        raise ValueError("K, S and the thickness must be >= 0")
    q = np.sqrt(k * (k + 2.0 * s))
    shape = np.broadcast_shapes(k.shape, t.shape)
    if np.isinf(t).any():
        return _deep_or_finite(k, s, q, t, shape)
    x = q * t  # optical depth in the effective attenuation
    e1 = np.exp(-x)
    e2 = e1 * e1
    # u = t (1 - e^-2x) / 2x, the scaled sinh(x)/q: its limit t at x = 0
    small = x < 1e-8
    ratio = np.where(small, 1.0, -np.expm1(-2.0 * x) / np.where(small, 1.0, 2.0 * x))
    u = t * ratio
    denominator = (s + k) * u + 0.5 * (1.0 + e2)
    return Layer(
        np.broadcast_to(s * u / denominator, shape).astype(np.float64),
        np.broadcast_to(e1 / denominator, shape).astype(np.float64),
    )


def _deep_or_finite(
    k: NDArray[np.float64],
    s: NDArray[np.float64],
    q: NDArray[np.float64],
    t: NDArray[np.float64],
    shape: tuple[int, ...],
) -> Layer:
    """:func:`layer` where some thicknesses are infinite (those give ``R_inf``, ``T = 0``)."""
    deep = np.broadcast_to(np.isinf(t), shape)
    finite = layer(k, s, np.where(np.isinf(t), 0.0, t))
    reflectance = np.where(deep, r_infinity(k, s), finite.reflectance)
    # K = 0 and S = 0: nothing happens however deep
    clear = np.broadcast_to(q == 0, shape) & np.broadcast_to(s == 0, shape)
    transmittance = np.where(deep, np.where(clear, 1.0, 0.0), finite.transmittance)
    return Layer(np.asarray(reflectance, np.float64), np.asarray(transmittance, np.float64))


def r_infinity(k: ArrayLike, s: ArrayLike) -> NDArray[np.float64]:
    """Reflectance of an infinitely thick layer, ``1 + K/S - sqrt((K/S)^2 + 2 K/S)``.

    Written as ``S / (S + K + sqrt(K (K + 2 S)))`` (equal, finite at ``S = 0``: 0).

    Examples
    --------
    >>> float(r_infinity(1.0, 4.0)[()])
    0.5
    """
    k, s = np.asarray(k, np.float64), np.asarray(s, np.float64)
    denominator = s + k
    denominator += np.sqrt(k * (k + 2.0 * s))
    out = np.zeros(denominator.shape)
    np.divide(s, denominator, out=out, where=denominator > 0)
    return out


def over(top: Layer, background: ArrayLike) -> NDArray[np.float64]:
    """Reflectance of a layer over a background of reflectance `background`.

    ``R = R_1 + T_1^2 R_b / (1 - R_1 R_b)``.

    Parameters
    ----------
    top : Layer
        ``(..., B)`` arrays.
    background : (..., B) float, [0, 1]

    Returns
    -------
    (..., B) float64
    """
    rb = np.asarray(background, np.float64)
    r, t = top
    return np.asarray(r + t * t * rb / (1.0 - r * rb), np.float64)


def stack(
    k: ArrayLike, s: ArrayLike, thickness_mm: ArrayLike, background: ArrayLike
) -> NDArray[np.float64]:
    """Reflectance (no surface) of layers, listed top first, over a background.

    Parameters
    ----------
    k, s : (L, ..., B) float, 1/mm
        Absorption and scattering of each of ``L`` layers, top first.
    thickness_mm : (L, ...) float, mm
    background : (..., B) float, [0, 1]
        What lies beneath the last layer.

    Returns
    -------
    (..., B) float64
    """
    layers = layer(k, s, thickness_mm)
    reflectance = np.asarray(background, np.float64)
    for r, t in zip(layers.reflectance[::-1], layers.transmittance[::-1], strict=True):
        reflectance = over(Layer(r, t), reflectance)  # loop over layers, bottom up
    return reflectance


def saunderson(
    reflectance: ArrayLike,
    k1: float = K1_DEFAULT,
    k2: float = K2_DEFAULT,
    *,
    specular_included: bool = True,
) -> NDArray[np.float64]:
    """Measured reflectance of a body under a resin surface.

    ``R_m = k1 + (1 - k1)(1 - k2) R / (1 - k2 R)`` with the specular reflection included
    (a d/8 SCI reading); without the leading ``k1`` when it is excluded (SCE, gloss trap).

    Examples
    --------
    >>> float(saunderson(0.0)[()]), float(saunderson(1.0)[()])
    (0.04, 1.0)
    """
    r = np.asarray(reflectance, np.float64)
    specular = k1 if specular_included else 0.0
    return np.asarray(specular + (1.0 - k1) * (1.0 - k2) * r / (1.0 - k2 * r), np.float64)


class Observer(NamedTuple):
    """Tristimulus weights of the model's bands.

    Attributes
    ----------
    weights : (B, 3) float64
        ``XYZ = R @ weights`` gives ``Y = 1`` for a perfect white.
    white_xy : (2,) float64
        Chromaticity of a perfect reflector at these bands (the CIELAB white: a flat
        spectrum is neutral, ``a* = b* = 0``).
    """

    weights: NDArray[np.float64]
    white_xy: NDArray[np.float64]


def observer(
    wavelengths_nm: ArrayLike = WAVELENGTHS_NM,
    *,
    illuminant: str = "D50",
    cmfs: str = "CIE 1931 2 Degree Standard Observer",
) -> Observer:
    """Weights turning reflectance at `wavelengths_nm` into XYZ under `illuminant`.

    The illuminant's spectral power times the colour-matching functions at the bands,
    normalised so that a perfect reflector has ``Y = 1`` (summation at the bands).
    """
    wavelengths = np.asarray(wavelengths_nm, np.float64)
    functions = colour.MSDS_CMFS[cmfs].copy().align(colour.SpectralShape(360, 830, 1))
    power = colour.SDS_ILLUMINANTS[illuminant].copy().align(colour.SpectralShape(360, 830, 1))
    xbar = np.stack(
        [np.interp(wavelengths, functions.wavelengths, functions.values[:, i]) for i in range(3)],
        axis=1,
    )
    spd = np.interp(wavelengths, power.wavelengths, power.values)
    weights = spd[:, None] * xbar
    weights /= weights[:, 1].sum()
    white = colour.XYZ_to_xy(weights.sum(axis=0))
    return Observer(weights, np.asarray(white, np.float64))


def reflectance_to_lab(reflectance: ArrayLike, seen: Observer) -> NDArray[np.float64]:
    """CIELAB ``(..., 3)`` of spectral reflectance ``(..., B)`` under the observer's light."""
    xyz = np.asarray(reflectance, np.float64) @ seen.weights
    return np.asarray(colour.XYZ_to_Lab(xyz, seen.white_xy), np.float64)


def srgb_to_lab_d50(rgb: ArrayLike, white_xy: ArrayLike | None = None) -> NDArray[np.float64]:
    """CIELAB (D50 white) of sRGB colours ``(..., 3)`` in ``[0, 1]``.

    sRGB (D65) to XYZ, Bradford to D50 (or `white_xy`), CIELAB.
    """
    white = np.asarray(
        colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
        if white_xy is None
        else white_xy
    )
    xyz = colour.RGB_to_XYZ(
        np.asarray(rgb, np.float64),
        colour.RGB_COLOURSPACES["sRGB"],
        illuminant=white,
        chromatic_adaptation_transform="Bradford",
        apply_cctf_decoding=True,
    )
    return np.asarray(colour.XYZ_to_Lab(xyz, white), np.float64)


def lab_d50_to_srgb8(lab: ArrayLike, white_xy: ArrayLike | None = None) -> NDArray[np.uint8]:
    """8-bit sRGB ``(..., 3) uint8`` of CIELAB (D50 white, or `white_xy`), clipped to sRGB.

    The inverse of :func:`srgb_to_lab_d50`: CIELAB to XYZ, Bradford to D65, sRGB.

    Examples
    --------
    >>> lab_d50_to_srgb8(srgb_to_lab_d50([0.2, 0.5, 0.8])).tolist()
    [51, 128, 204]
    """
    white = np.asarray(
        colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
        if white_xy is None
        else white_xy
    )
    xyz = colour.Lab_to_XYZ(np.asarray(lab, np.float64), white)
    rgb = colour.XYZ_to_RGB(
        xyz,
        colour.RGB_COLOURSPACES["sRGB"],
        illuminant=white,
        chromatic_adaptation_transform="Bradford",
        apply_cctf_encoding=True,
    )
    encoded: NDArray[np.uint8] = np.rint(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
    return encoded
