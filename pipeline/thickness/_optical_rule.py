"""The optical rule: a face's colour layer is as deep as its colour needs to settle.

``rule = "optical"`` (the default). Each face's robust colour goes through the printer's
separation to its mix of materials; under the printer's two-flux model
(:class:`shellvox.voxel.colour._settling.LayerModel`) the mix, ``t`` deep over what the build
puts beneath it (the backing layers over the core), shows a colour that tends to the
same mix infinitely deep. The face's colour layer is its *settling depth*: the least
``t`` from which on that colour stays within ``delta_e`` CIEDE2000 of the deep one
(:func:`shellvox.voxel.colour._settling.settling_depth`). A mix still changing at ``max_mm`` (mixes
diluted with clear material, which hardly scatters) is flagged as not settled and gets
``max_mm``. The common limits and the smoothing of :mod:`shellvox.thickness._rule` follow.

A face's depth serves all of it: it is the deepest settling depth among the face's
colour samples (:func:`shellvox.thickness._face_colour.face_samples`: the texels a
textured face covers, a vertex-coloured face's corners), so a texture detail that needs
more depth than the face's robust colour (a yellow line on a grey face) gets it. The
robust colour's own mix and depth are kept beside it, to show why.

Equal colours are settled once.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.thickness._face_colour import FaceColour
from shellvox.thickness._rule import ThicknessRule
from shellvox.voxel.colour import LayerModel, Settling, lab_to_srgb8


class OpticalFaces(NamedTuple):
    """What the optical rule found per face.

    Attributes
    ----------
    thickness_mm : (F,) float64, mm
        The deepest settling depth among the face's colour samples (``max_mm`` where one
        does not settle), before the common limits.
    shares : (F, P) float64
        The separation's shares of the face's robust colour (columns as the separation's
        roles).
    settled : (F,) bool
        Every colour sample of the face settles within ``max_mm``.
    deep_lab : (F, 3) float64
        CIELAB (D50) of the robust colour's mix infinitely deep.
    roles : tuple of str
        Role of each column of ``shares``.
    robust_mm : (F,) float64, mm
        Settling depth of the robust colour alone (``<= thickness_mm``).
    deepest_rgba : (F, 4) uint8
        The colour sample (sRGB + alpha) that needs ``thickness_mm``.
    """

    thickness_mm: NDArray[np.float64]
    shares: NDArray[np.float64]
    settled: NDArray[np.bool_]
    deep_lab: NDArray[np.float64]
    roles: tuple[str, ...]
    robust_mm: NDArray[np.float64]
    deepest_rgba: NDArray[np.uint8]


def face_rgba(colour: FaceColour) -> NDArray[np.uint8]:
    """Return each face's robust colour as sRGB + alpha ``(F, 4) uint8``."""
    rgba = np.empty((len(colour.lab), 4), np.uint8)
    rgba[:, :3] = lab_to_srgb8(colour.lab)
    rgba[:, 3] = np.rint(np.clip(colour.alpha, 0.0, 1.0) * 255.0).astype(np.uint8)
    return rgba


def optical_thickness(
    colour: FaceColour,
    model: LayerModel,
    rule: ThicknessRule,
    samples: Iterable[tuple[NDArray[np.int64], NDArray[np.uint8]]] | None = None,
) -> OpticalFaces:
    """Return each face's settling depth and mix (see the module).

    Parameters
    ----------
    colour : FaceColour
        Robust colour per face.
    model : LayerModel
        The printer's optics, separation and what lies beneath the colour layer.
    rule : ThicknessRule
        ``colour_layer.delta_e`` and ``colour_layer.max_mm``.
    samples : iterable of (faces (C,) int64, rgba (C, S, 4) uint8), optional
        Every face's colour samples (:func:`~shellvox.thickness._face_colour.face_samples`);
        without them each face's depth is its robust colour's.
    """
    rgba = face_rgba(colour)
    settle = _Settler(model, rule)
    shares, robust = settle.robust(rgba)
    depth, settled, deepest = robust.depth_mm, robust.settled, rgba
    if samples is not None:
        depth, settled, deepest = depth.copy(), settled.copy(), rgba.copy()
        for faces, chunk in samples:  # loop over chunks of faces, not faces
            need, ok = settle.samples(chunk.reshape(-1, 4))
            need, ok = need.reshape(chunk.shape[:2]), ok.reshape(chunk.shape[:2])
            pick = np.argmax(need, axis=1)
            rows = np.arange(len(faces))
            deeper = need[rows, pick] > depth[faces]
            depth[faces[deeper]] = need[rows, pick][deeper]
            deepest[faces[deeper]] = chunk[rows, pick][deeper]
            settled[faces] &= ok.all(axis=1)
    return OpticalFaces(
        depth, shares, settled, robust.deep_lab, model.separation.roles, robust.depth_mm, deepest
    )


class _Settler:
    """Settling depths of sRGBA colours, each distinct colour settled once."""

    def __init__(self, model: LayerModel, rule: ThicknessRule) -> None:
        self.model, self.layer = model, rule.colour_layer
        self.keys = np.zeros(0, np.uint32)  # packed RGBA, sorted
        self.depth = np.zeros(0, np.float64)
        self.settled = np.zeros(0, bool)

    def _settle(self, shares: NDArray[np.float64]) -> Settling:
        return self.model.settle(shares, delta_e=self.layer.delta_e, max_mm=self.layer.max_mm)

    def robust(self, rgba: NDArray[np.uint8]) -> tuple[NDArray[np.float64], Settling]:
        """Shares ``(F, P)`` and settling of colours ``(F, 4) uint8`` (remembered)."""
        distinct, inverse = np.unique(rgba, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        shares = self.model.shares(distinct)
        found = self._settle(shares)
        self._remember(_packed(distinct), found)
        return shares[inverse], Settling(
            found.depth_mm[inverse], found.settled[inverse], found.deep_lab[inverse]
        )

    def samples(self, rgba: NDArray[np.uint8]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Settling depth ``(N,)`` mm and whether settled ``(N,)`` of colours ``(N, 4)``."""
        keys = _packed(rgba)
        distinct, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        new = ~np.isin(distinct, self.keys)
        if new.any():
            found = self._settle(self.model.shares(rgba[first[new]]))
            self._remember(distinct[new], found)
        at = np.searchsorted(self.keys, distinct)
        return self.depth[at][inverse], self.settled[at][inverse]

    def _remember(self, keys: NDArray[np.uint32], found: Settling) -> None:
        keys = np.concatenate([self.keys, keys])
        order = np.argsort(keys, kind="stable")
        self.keys = keys[order]
        self.depth = np.concatenate([self.depth, found.depth_mm])[order]
        self.settled = np.concatenate([self.settled, found.settled])[order]


def _packed(rgba: NDArray[np.uint8]) -> NDArray[np.uint32]:
    """``(N, 4) uint8`` colours as one ``uint32`` each (R most significant)."""
    packed = np.ascontiguousarray(rgba, np.uint8).view(">u4").reshape(-1)
    return packed.astype(np.uint32)
