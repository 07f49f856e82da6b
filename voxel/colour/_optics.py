"""The printer's optics: absorption and scattering of every material, and their defaults.

An :class:`Optics` holds what the two-flux model (:mod:`kubelka_munk`) needs to predict
a printed colour: the wavelength bands, Saunderson's ``k1``, ``k2`` and each material's
``K`` and ``S`` per band (1/mm). A printer profile gives them in its ``[optics]`` table
and per material (``km_k_per_mm``, ``km_s_per_mm``); where it does not,
:func:`assumed_optics` derives them, and says so (``assumed``):

1. Each material's reflectance of a deep patch is the smooth reflectance spectrum of its
   display colour (colour-science's ``RGB_to_sd_Mallett2019``, which keeps reflectance in
   ``[0, 1]``), taken as measured with the surface (specular included).
2. Saunderson's relation is inverted for the body reflectance ``R_inf``, the display
   colour taken as seen without the gloss (specular excluded: a display colour is what
   the part looks like, and a viewer avoids the glare; read with the gloss included,
   every printed colour would be lighter than ``k1`` allows and the strong colourants'
   absorption would have no bound).
3. An assumed scattering per role (:data:`ASSUMED_SCATTERING_PER_MM`: white scatters
   strongly, the colours weakly, clear almost not), and ``K = S (1 - R_inf)^2 / (2 R_inf)``
   (the Kubelka-Munk function), so that a deep patch shows the display colour.

These are assumptions, not measurements: no measured K and S of Vero materials could be
verified here (Kissel et al. 2025, Elek et al. 2021 and Iser et al. 2022 publish measured
transport parameters). A printed, measured chart replaces them (``shellvox calibrate``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.voxel.colour._kubelka_munk import K1_DEFAULT, K2_DEFAULT, WAVELENGTHS_NM

#: Assumed scattering (1/mm, flat over the bands) of each role without measurements.
#: White pigments (TiO2) scatter strongly, dyed colour resins weakly, clear resin hardly.
ASSUMED_SCATTERING_PER_MM = {
    "white": 20.0,
    "cyan": 1.0,
    "magenta": 1.0,
    "yellow": 1.0,
    "black": 2.0,
    "clear": 0.01,
    "support": 10.0,
}

#: Assumed absorption of clear resin (1/mm, flat): a 10 mm clear path keeps about 90 %.
ASSUMED_CLEAR_ABSORPTION_PER_MM = 0.01

#: Darkest body reflectance derived from a display colour (its K/S stays finite).
MIN_BODY_REFLECTANCE = 1e-3


@dataclass(frozen=True, eq=False)
class Optics:
    """Two-flux parameters of a printer's materials.

    Parameters
    ----------
    names, roles : tuple of str
        Each of the ``M`` materials (the void excluded).
    wavelengths_nm : (B,) float64, nm
    k1, k2 : float
        Saunderson's external and internal surface reflectance.
    k_per_mm, s_per_mm : (M, B) float64, 1/mm
        Absorption and scattering per material and band.
    assumed : bool
        Derived by :func:`assumed_optics`, not measured.
    """

    names: tuple[str, ...]
    roles: tuple[str, ...]
    wavelengths_nm: NDArray[np.float64]
    k1: float
    k2: float
    k_per_mm: NDArray[np.float64]
    s_per_mm: NDArray[np.float64]
    assumed: bool

    def __post_init__(self) -> None:
        m, b = len(self.names), len(self.wavelengths_nm)
        for name in ("k_per_mm", "s_per_mm"):
            value = getattr(self, name)
            if value.shape != (m, b) or not np.isfinite(value).all() or (value < 0).any():
                raise ValueError(
                    f"{name} must be ({m}, {b}) finite and >= 0 (materials, bands), "
                    f"got shape {value.shape}"
                )
        if not (0 <= self.k1 < 1 and 0 <= self.k2 < 1):
            raise ValueError(f"k1 and k2 must be in [0, 1), got {self.k1}, {self.k2}")

    def manifest(self) -> dict[str, object]:
        """Return the parameters as the manifest records them.

        Each material's ``index`` is its index in the material volume (row ``i`` is
        material ``i + 1``; 0 is the void).
        """
        return {
            "model": "kubelka-munk",
            "wavelengths_nm": self.wavelengths_nm.tolist(),
            "k1": self.k1,
            "k2": self.k2,
            "illuminant": "D50",
            "observer": "CIE 1931 2 Degree Standard Observer",
            "assumed": self.assumed,
            "materials": [
                {
                    "index": i + 1,
                    "name": n,
                    "role": r,
                    "k_per_mm": k.tolist(),
                    "s_per_mm": s.tolist(),
                }
                for i, (n, r, k, s) in enumerate(
                    zip(self.names, self.roles, self.k_per_mm, self.s_per_mm, strict=True)
                )
            ],
        }


def body_reflectance(
    measured: ArrayLike, k1: float, k2: float, *, specular_included: bool = True
) -> NDArray[np.float64]:
    """Invert Saunderson's relation: the body reflectance under a measured one.

    ``R = A / (1 + k2 A)`` with ``A = (R_m - k1) / ((1 - k1)(1 - k2))`` (``R_m`` alone in
    the numerator without the specular reflection), kept within
    ``[MIN_BODY_REFLECTANCE, 1 - MIN_BODY_REFLECTANCE]``.
    """
    specular = k1 if specular_included else 0.0
    a = (np.asarray(measured, np.float64) - specular) / ((1.0 - k1) * (1.0 - k2))
    return np.clip(a / (1.0 + k2 * a), MIN_BODY_REFLECTANCE, 1.0 - MIN_BODY_REFLECTANCE)


def display_reflectance(
    display_srgb: ArrayLike, wavelengths_nm: ArrayLike = WAVELENGTHS_NM
) -> NDArray[np.float64]:
    """Smooth reflectance spectra ``(M, B)`` of sRGB display colours ``(M, 3)`` uint8.

    colour-science's Mallett and Yuksel (2019) recovery: its spectra reproduce the colour
    under D65 and stay within ``[0, 1]``.
    """
    wavelengths = np.asarray(wavelengths_nm, np.float64)
    linear = colour.cctf_decoding(np.asarray(display_srgb, np.float64) / 255.0, function="sRGB")
    rows = []
    for rgb in np.atleast_2d(linear):  # loop over materials
        sd = colour.recovery.RGB_to_sd_Mallett2019(rgb)
        rows.append(np.interp(wavelengths, sd.wavelengths, sd.values))
    return np.clip(np.array(rows, np.float64), 0.0, 1.0)


def assumed_optics(
    names: Sequence[str],
    roles: Sequence[str],
    display_srgb: ArrayLike,
    *,
    wavelengths_nm: ArrayLike = WAVELENGTHS_NM,
    k1: float = K1_DEFAULT,
    k2: float = K2_DEFAULT,
) -> Optics:
    """Optics derived from display colours and assumed scattering (see the module).

    Parameters
    ----------
    names, roles : sequence of str
        The ``M`` printed materials (no void); roles among
        :data:`ASSUMED_SCATTERING_PER_MM`.
    display_srgb : (M, 3) uint8-valued
        Each material's display colour (a deep patch, as seen).
    """
    wavelengths = np.asarray(wavelengths_nm, np.float64)
    unknown = sorted(set(roles) - set(ASSUMED_SCATTERING_PER_MM))
    if unknown:
        raise ValueError(f"no assumed scattering for roles {unknown}")
    s = np.array([[ASSUMED_SCATTERING_PER_MM[r]] * len(wavelengths) for r in roles])
    measured = display_reflectance(display_srgb, wavelengths)
    body = body_reflectance(measured, k1, k2, specular_included=False)
    k = s * (1.0 - body) ** 2 / (2.0 * body)
    clear = np.array([r == "clear" for r in roles])
    k[clear] = ASSUMED_CLEAR_ABSORPTION_PER_MM
    return Optics(tuple(names), tuple(roles), wavelengths, k1, k2, k, s, assumed=True)
