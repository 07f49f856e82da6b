"""The depth at which a colour layer's colour stops changing: its *settling depth*.

A face's colour layer is a mix of materials (its separation) of depth ``t`` over what
the build puts beneath it (backing layers, then the core). Under the two-flux model
(:mod:`kubelka_munk`) its colour, seen through the resin surface, tends to the colour
of the same mix infinitely deep as ``t`` grows. The settling depth is the least ``t``
from which on the colour stays within ``delta_e`` (CIEDE2000) of that deep colour:

1. ``dE(t)`` is evaluated on a log-spaced ladder of depths up to ``max_mm``;
2. the last ladder step still farther than ``delta_e`` and the next one bracket the
   depth, which is then bisected (``dE`` is continuous in ``t``);
3. a mix that is still farther than ``delta_e`` at ``max_mm`` has not settled (a mix
   diluted with clear material, which hardly scatters): its depth is ``max_mm`` and it
   is flagged.

Everything is vectorised over the mixes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.voxel.colour._kubelka_munk import (
    Observer,
    layer,
    mix,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
)
from shellvox.voxel.colour._optics import Optics
from shellvox.voxel.colour._separation import Separation

#: Depths of the ladder (log-spaced from 10 um) and bisection steps.
LADDER_STEPS = 40
BISECTIONS = 30


class Settling(NamedTuple):
    """Settling depths of mixes.

    Attributes
    ----------
    depth_mm : (N,) float64, mm
        Least depth from which the colour stays within ``delta_e`` of the deep colour
        (``max_mm`` where it has not settled).
    settled : (N,) bool
        The colour is within ``delta_e`` at ``max_mm``.
    deep_lab : (N, 3) float64
        CIELAB of the mix infinitely deep.
    """

    depth_mm: NDArray[np.float64]
    settled: NDArray[np.bool_]
    deep_lab: NDArray[np.float64]


def settling_depth(
    k: ArrayLike,
    s: ArrayLike,
    background: ArrayLike,
    seen: Observer,
    *,
    k1: float,
    k2: float,
    delta_e: float = 1.0,
    max_mm: float = 3.0,
) -> Settling:
    """Settling depth of layers of absorption `k` and scattering `s` over `background`.

    Parameters
    ----------
    k, s : (N, B) float, 1/mm
        Each mix's absorption and scattering per band.
    background : (B,) or (N, B) float, [0, 1]
        Body reflectance of what lies beneath the colour layer.
    seen : Observer
        The bands' tristimulus weights.
    k1, k2 : float
        Saunderson's surface reflectances.
    delta_e : float
        CIEDE2000 within which the colour counts as settled.
    max_mm : float, mm
        Deepest depth considered.
    """
    k, s = np.asarray(k, np.float64), np.asarray(s, np.float64)
    rb = np.broadcast_to(np.asarray(background, np.float64), k.shape)
    deep = reflectance_to_lab(saunderson(r_infinity(k, s), k1, k2), seen)

    def distance(t: NDArray[np.float64]) -> NDArray[np.float64]:
        lab = reflectance_to_lab(saunderson(over(layer(k, s, t), rb), k1, k2), seen)
        return np.asarray(colour.delta_E(lab, deep, method="CIE 2000"), np.float64)

    ladder = np.geomspace(0.01, max_mm, LADDER_STEPS)
    far = np.stack([distance(np.full(len(k), t)) > delta_e for t in ladder], 1)  # (N, L)
    settled = ~far[:, -1]
    # the last rung still far: the depth lies between it and the next one
    last = np.where(far.any(1), LADDER_STEPS - 1 - np.argmax(far[:, ::-1], axis=1), -1)
    low = np.where(last >= 0, ladder[np.clip(last, 0, None)], 0.0)
    high = ladder[np.clip(last + 1, 0, LADDER_STEPS - 1)]
    for _ in range(BISECTIONS):  # bisection, all mixes at once
        middle = 0.5 * (low + high)
        is_far = distance(middle) > delta_e
        low, high = np.where(is_far, middle, low), np.where(is_far, high, middle)
    depth = np.where(settled, high, max_mm)
    return Settling(depth, settled, deep)


@dataclass(frozen=True, eq=False)
class LayerModel:
    """What the optical thickness rule needs of a printer and a build.

    Parameters
    ----------
    optics : Optics
        The printed materials' K and S.
    separation : Separation
        The colour of a face to its materials' shares.
    rows : tuple of int
        Row of ``optics`` of each separation column.
    background : (B,) float64, [0, 1]
        Body reflectance of what the build puts beneath the colour layer (backing
        layers over the core).
    """

    optics: Optics
    separation: Separation
    rows: tuple[int, ...]
    background: NDArray[np.float64]

    def shares(self, rgba: NDArray[np.uint8]) -> NDArray[np.float64]:
        """Return the separation's shares ``(N, P)`` of sRGBA colours ``(N, 4) uint8``."""
        return np.asarray(self.separation.proportions(rgba), np.float64)

    def absorption_scattering(
        self, shares: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Return K and S ``(N, B)`` (1/mm) of mixes ``(N, P)`` (Duncan)."""
        rows = list(self.rows)
        return mix(shares, self.optics.k_per_mm[rows]), mix(shares, self.optics.s_per_mm[rows])

    def deep_lab(self, shares: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return CIELAB (D50) ``(N, 3)`` of mixes ``(N, P)`` infinitely deep."""
        k, s = self.absorption_scattering(shares)
        seen = observer(self.optics.wavelengths_nm)
        body = r_infinity(k, s)
        return reflectance_to_lab(saunderson(body, self.optics.k1, self.optics.k2), seen)

    def distance_at(
        self, shares: NDArray[np.float64], depth_mm: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Return CIEDE2000 ``(N,)`` of each mix `depth_mm` deep against it deep.

        The mix lies over :attr:`background`; both are seen through the surface.
        """
        k, s = self.absorption_scattering(shares)
        seen = observer(self.optics.wavelengths_nm)
        optics = self.optics
        shown = over(layer(k, s, depth_mm), np.broadcast_to(self.background, k.shape))
        lab = reflectance_to_lab(saunderson(shown, optics.k1, optics.k2), seen)
        deep = reflectance_to_lab(saunderson(r_infinity(k, s), optics.k1, optics.k2), seen)
        return np.asarray(colour.delta_E(lab, deep, method="CIE 2000"), np.float64)

    def settle(self, shares: NDArray[np.float64], *, delta_e: float, max_mm: float) -> Settling:
        """Return the settling depths of mixes ``(N, P)`` over :attr:`background`.

        Equal mixes are settled once.
        """
        distinct, inverse = np.unique(np.asarray(shares, np.float64), axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        k, s = self.absorption_scattering(distinct)
        seen = observer(self.optics.wavelengths_nm)
        found = settling_depth(
            k,
            s,
            self.background,
            seen,
            k1=self.optics.k1,
            k2=self.optics.k2,
            delta_e=delta_e,
            max_mm=max_mm,
        )
        return Settling(found.depth_mm[inverse], found.settled[inverse], found.deep_lab[inverse])
