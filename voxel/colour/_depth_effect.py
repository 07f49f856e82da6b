"""What per-face depth buys: the optical rule against one constant depth, under the model.

At surface samples (uniform by area) with their mixes (the separation of their target
colours), the two-flux model gives each sample's colour at a colour-layer depth over the
backing and core, and its settling depth (:class:`shellvox.voxel.colour._settling.LayerModel`).
Two questions, both answered per share of the surface:

- **Coverage at equal volume**: with the build's per-face depths, and with one constant
  depth equal to their mean (the same colour-layer volume), the share of the surface
  whose colour is within ``delta_e`` of its settled (infinitely deep) colour.
- **Volume for 95 % coverage**: one constant depth must reach the 95th percentile of the
  settling depths; per-face depths need only each sample's own settling depth (capped at
  that percentile). Their ratio is the volume a constant layer wastes.
- **Volume for the same coverage**: the constant depth that covers the share the build's
  depths cover (that percentile of the settling depths) against the build's mean depth:
  where 95 % cannot settle within ``max_mm`` (colours diluted with clear, weakly
  scattering mixes), the comparison at the coverage reached.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._settling import LayerModel


def depth_effect(
    model: LayerModel,
    shares: NDArray[np.float64],
    depth_mm: NDArray[np.float64],
    *,
    delta_e: float = 1.0,
    max_mm: float = 3.0,
) -> dict[str, Any]:
    """Compare per-sample depths with one constant depth of the same mean (see the module).

    Parameters
    ----------
    model : LayerModel
        Optics, separation and background.
    shares : (N, P) float64
        Each sample's mix.
    depth_mm : (N,) float64, mm
        The colour-layer depth under each sample as built.
    delta_e : float
        CIEDE2000 within which a colour counts as settled.
    max_mm : float, mm
        Deepest settling depth searched.

    Returns
    -------
    dict
        ``mean_depth_mm``; ``covered_share`` of ``adaptive`` and ``constant``;
        ``for_95_percent``: ``constant_mm``, ``adaptive_mean_mm`` and
        ``constant_over_adaptive`` (None where 95 % do not settle within ``max_mm``);
        ``for_same_coverage``: ``covered_share``, ``constant_mm``, ``adaptive_mean_mm`` and
        ``constant_over_adaptive`` (None where that share does not settle within
        ``max_mm``).
    """
    depth = np.asarray(depth_mm, np.float64)
    mean = float(depth.mean())
    adaptive = model.distance_at(shares, depth) <= delta_e
    constant = model.distance_at(shares, np.full(len(depth), mean)) <= delta_e
    settling = model.settle(shares, delta_e=delta_e, max_mm=max_mm)
    # a sample that does not settle counts as deeper than any: past max_mm
    needed = np.where(settling.settled, settling.depth_mm, 2 * max_mm)
    q95 = float(np.percentile(needed, 95))
    q95 = q95 if q95 <= max_mm else np.inf
    for_95: dict[str, float | None] = {
        "constant_mm": None,
        "adaptive_mean_mm": None,
        "constant_over_adaptive": None,
    }
    if np.isfinite(q95):
        adaptive_mean = float(np.minimum(needed, q95).mean())
        for_95 = {
            "constant_mm": round(q95, 6),
            "adaptive_mean_mm": round(adaptive_mean, 6),
            "constant_over_adaptive": round(q95 / adaptive_mean, 6) if adaptive_mean > 0 else None,
        }
    covered = float(adaptive.mean())
    reach = float(np.quantile(needed, covered, method="inverted_cdf")) if covered > 0 else 0.0
    same: dict[str, float | None] = {
        "covered_share": round(covered, 6),
        "constant_mm": None,
        "adaptive_mean_mm": round(mean, 6),
        "constant_over_adaptive": None,
    }
    if reach <= max_mm:
        same["constant_mm"] = round(reach, 6)
        same["constant_over_adaptive"] = round(reach / mean, 6) if mean > 0 else None
    return {
        "delta_e": delta_e,
        "mean_depth_mm": round(mean, 6),
        "adaptive": {"covered_share": round(float(adaptive.mean()), 6)},
        "constant": {"covered_share": round(float(constant.mean()), 6)},
        "not_settled_share": round(float((~settling.settled).mean()), 6),
        "for_95_percent": for_95,
        "for_same_coverage": same,
    }
