"""The lightness rule: a colour layer from lightness, chroma and transparency (a judgment).

``rule = "lightness"`` in a rule file. The colour layer of a face with robust colour
``L*``, ``C*`` and alpha ``a`` is, before the common limits of
:mod:`shellvox.thickness._rule`::

    s = (w_L L*/100 + w_C (1 - min(C*/C_full, 1)) + w_T (1 - a)) / (w_L + w_C + w_T)
    t = min_mm + (max_mm - min_mm) s

It is kept to compare with the optical rule, which derives the depth from the printer's
optics instead. Why its defaults (:data:`shellvox.thickness._rule.LIGHTNESS_RULE`;
judgments from printer facts, not measurements):

- **0.3 to 1.2 mm.** A colour layer must hold a few voxels across its depth on every
  side: the J750 grid is 42 x 85 x 27 um (600 x 300 dpi, 27 um layers), so 0.3 mm is
  3.5 voxels along the coarsest axis. Beyond about 1 mm a deeper colour layer mostly adds
  scattering in (translucent) colour material without changing the colour seen; 1.2 mm
  leaves room for translucent colours.
- **Lighter, less saturated, more transparent is thicker** (weights 0.6, 0.2, 0.2). A
  light or greyish colour is mostly white or clear material with sparse cyan, magenta,
  yellow or black voxels; the eye averages the halftone over the depth it sees into, so
  sparse colour needs more depth to average smoothly and to hide the backing. A dark or
  saturated colour is dense absorbing material and is set in the first tenths of a
  millimetre. Translucency brings in clear material, which dilutes the colour: by
  Beer-Lambert the absorbance is concentration x depth, so a thinner concentration needs
  more depth. Lightness weighs most because it sets ink coverage most directly.
  Chroma counts as full from ``C* = 100`` (about sRGB's red, 104; only blues reach 133).
  With these numbers: white 1.02 mm, mid grey 0.77 mm, yellow 0.83 mm, red 0.59 mm,
  black 0.48 mm, clear white 1.2 mm (upper surfaces).
- **Orientation** (upper ``n_z > 0.5``, lower ``n_z < -0.05``, else side): upper 1.0,
  side 1.1, lower 1.2. PolyJet prints every overhang on support material, and
  support-contact surfaces come out matte (University of Cologne RRZK, "Notes on the 3D
  printing form", https://rrzk.uni-koeln.de/en/software-multimedia/3d-scan-and-3d-printing/
  3d-printing/notes-on-the-3d-printing-form): surface scatter lightens and desaturates
  them, which a deeper colour layer partly offsets. A side face's depth is resolved by
  42-85 um voxels instead of 27 um layers, so half a voxel of boundary error is a larger
  share of its depth.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shellvox.thickness._rule import ThicknessRule


def lightness_thickness(
    lightness: NDArray[np.float64],
    chroma: NDArray[np.float64],
    alpha: NDArray[np.float64],
    rule: ThicknessRule,
) -> NDArray[np.float64]:
    """Evaluate the lightness rule per face, before the common limits.

    Parameters
    ----------
    lightness : (F,) float64
        ``L*`` in ``[0, 100]``.
    chroma : (F,) float64
        ``C*_ab`` (``>= 0``).
    alpha : (F,) float64
        Alpha in ``[0, 1]`` (1 opaque).
    rule : ThicknessRule

    Returns
    -------
    (F,) float64, mm
        In ``[min_mm, max_mm]``.

    Examples
    --------
    >>> from shellvox.thickness import LIGHTNESS_RULE
    >>> one = np.ones(1)
    >>> white = lightness_thickness(100 * one, 0 * one, one, LIGHTNESS_RULE)
    >>> round(float(white[0]), 6)
    1.02
    """
    c = rule.colour_layer
    total = c.lightness_weight + c.neutral_weight + c.transparency_weight
    score = (
        c.lightness_weight * np.clip(lightness / 100.0, 0.0, 1.0)
        + c.neutral_weight * (1.0 - np.clip(chroma / c.full_chroma, 0.0, 1.0))
        + c.transparency_weight * (1.0 - np.clip(alpha, 0.0, 1.0))
    ) / total
    thickness: NDArray[np.float64] = c.min_mm + (c.max_mm - c.min_mm) * score
    return thickness
