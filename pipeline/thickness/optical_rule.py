"""The optical rule: a face's colour layer is as deep as its colour needs to settle.

``rule = "optical"`` (the default). Each face's robust colour goes through the printer's
separation to its mix of materials; under the printer's two-flux model
(:class:`voxel.colour.settling.LayerModel`) the mix, ``t`` deep over what the build
puts beneath it (the backing layers over the core), shows a colour that tends to the
same mix infinitely deep. The face's colour layer is its *settling depth*: the least
``t`` from which on that colour stays within ``delta_e`` CIEDE2000 of the deep one
(:func:`voxel.colour.settling.settling_depth`). A mix still changing at ``max_mm`` (mixes
diluted with clear material, which hardly scatters) is flagged as not settled and gets
``max_mm``. The common limits and the smoothing of :mod:`pipeline.thickness.rule` follow.

Faces of equal colour are settled once.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pipeline.thickness.face_colour import FaceColour
from pipeline.thickness.rule import ThicknessRule
from voxel.colour.settling import LayerModel
from voxel.colour.srgb import lab_to_srgb8


class OpticalFaces(NamedTuple):
    """What the optical rule found per face.

    Attributes
    ----------
    thickness_mm : (F,) float64, mm
        Settling depth (``max_mm`` where not settled), before the common limits.
    shares : (F, P) float64
        The separation's shares of the face's colour (columns as the separation's roles).
    settled : (F,) bool
        The colour settles within ``max_mm``.
    deep_lab : (F, 3) float64
        CIELAB (D50) of the face's mix infinitely deep.
    roles : tuple of str
        Role of each column of ``shares``.
    """

    thickness_mm: NDArray[np.float64]
    shares: NDArray[np.float64]
    settled: NDArray[np.bool_]
    deep_lab: NDArray[np.float64]
    roles: tuple[str, ...]


def face_rgba(colour: FaceColour) -> NDArray[np.uint8]:
    """Return each face's robust colour as sRGB + alpha ``(F, 4) uint8``."""
    rgba = np.empty((len(colour.lab), 4), np.uint8)
    rgba[:, :3] = lab_to_srgb8(colour.lab)
    rgba[:, 3] = np.rint(np.clip(colour.alpha, 0.0, 1.0) * 255.0).astype(np.uint8)
    return rgba


def optical_thickness(colour: FaceColour, model: LayerModel, rule: ThicknessRule) -> OpticalFaces:
    """Return each face's settling depth and mix (see the module).

    Parameters
    ----------
    colour : FaceColour
        Robust colour per face.
    model : LayerModel
        The printer's optics, separation and what lies beneath the colour layer.
    rule : ThicknessRule
        ``colour_layer.delta_e`` and ``colour_layer.max_mm``.
    """
    rgba = face_rgba(colour)
    distinct, inverse = np.unique(rgba, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    shares = model.shares(distinct)
    layer = rule.colour_layer
    found = model.settle(shares, delta_e=layer.delta_e, max_mm=layer.max_mm)
    return OpticalFaces(
        found.depth_mm[inverse],
        shares[inverse],
        found.settled[inverse],
        found.deep_lab[inverse],
        model.separation.roles,
    )
