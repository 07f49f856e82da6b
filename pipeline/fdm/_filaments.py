"""Filaments: parsing ``#RRGGBB`` lists and mapping colours to the nearest filament.

The nearest filament is the one with the smallest CIEDE2000 difference (colour-science,
``colour.delta_E(method="CIE 2000")``) between CIELAB (D65) colours, the conversion
:mod:`shellvox.thickness._face_colour` uses for the model's faces.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import colour
import numpy as np
from numpy.typing import NDArray

from shellvox.errors import FdmError, opt
from shellvox.voxel._compiled import kernel
from shellvox.voxel.colour import srgb8_to_lab

_HEX = re.compile(r"#?([0-9A-Fa-f]{6})")


@dataclass(frozen=True, eq=False)
class Filaments:
    """The filaments of a project, the core's first.

    Attributes
    ----------
    rgb : (N, 3) uint8
        sRGB of each filament, in ``[0, 255]``.
    lab : (N, 3) float64
        CIELAB (D65) of each filament.
    """

    rgb: NDArray[np.uint8]
    lab: NDArray[np.float64]

    @property
    def hex(self) -> tuple[str, ...]:
        """``"#RRGGBB"`` of each filament (upper case)."""
        return tuple("#{:02X}{:02X}{:02X}".format(*(int(c) for c in row)) for row in self.rgb)

    def __len__(self) -> int:
        return int(self.rgb.shape[0])


def parse_filaments(text: str | Sequence[str], *, option: str = "filaments") -> Filaments:
    """Parse ``#RRGGBB,#RRGGBB,...`` (at least two; the first is the core's).

    Raises
    ------
    FdmError
        Fewer than two colours, or one that is not ``#RRGGBB``.

    Examples
    --------
    >>> parse_filaments("#ffffff,#FF0000").hex
    ('#FFFFFF', '#FF0000')
    """
    parts = text.replace(" ", "").split(",") if isinstance(text, str) else list(text)
    if len(parts) < 2:
        raise FdmError(
            opt(option),
            f"needs at least two filaments (the core's and a skin colour), got {len(parts)}",
            f"pass e.g. {opt('filaments', '#FFFFFF,#FF0000')}",
        )
    rgb = np.empty((len(parts), 3), np.uint8)
    for i, part in enumerate(parts):
        match = _HEX.fullmatch(part)
        if match is None:
            raise FdmError(
                opt(option),
                f"filament {i + 1} is not a colour #RRGGBB, got {part!r}",
                "pass sRGB colours as #RRGGBB, e.g. #FF8000",
            )
        rgb[i] = np.frombuffer(bytes.fromhex(match.group(1)), np.uint8)
    return Filaments(rgb=rgb, lab=srgb8_to_lab(rgb))


def nearest_filament(
    lab: NDArray[np.float64], filaments: Filaments, *, neighbours: NDArray[np.int64] | None = None
) -> NDArray[np.int64]:
    """Return the index of the nearest filament (CIEDE2000) for every colour.

    Parameters
    ----------
    lab : (F, 3) float64
        CIELAB (D65) colours, e.g. :attr:`FaceColour.lab`.
    filaments : Filaments
    neighbours : (F, 3) int64, optional
        Face adjacency (``-1`` for none). Given, the choice is dithered: each face's
        CIELAB error (its colour minus its filament's) is spread evenly over its
        neighbours not yet chosen (:func:`_dithered`).

    Returns
    -------
    (F,) int64
        Indices into the filaments, in ``[0, N)``.

    Examples
    --------
    >>> f = parse_filaments("#FFFFFF,#FF0000,#0000FF")
    >>> nearest_filament(srgb8_to_lab(np.array([[250, 10, 10], [20, 20, 200]], np.uint8)), f)
    array([1, 2])
    """
    lab = np.asarray(lab, np.float64)
    if neighbours is None:
        distance = colour.delta_E(lab[:, None, :], filaments.lab[None, :, :], method="CIE 2000")
        return np.asarray(np.argmin(distance, axis=1), np.int64)
    return _dithered(lab, filaments, np.asarray(neighbours, np.int64))


def _dithered(
    lab: NDArray[np.float64], filaments: Filaments, neighbours: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Error diffusion over the faces, a class of mutually non-adjacent faces at a time.

    The faces are split into classes no two neighbours share (:func:`_face_classes`);
    the classes are visited in turn, every face of one at once: each takes its nearest
    filament, and its error goes in equal shares to its neighbours of later classes.
    """
    target = lab.copy()
    classes = _face_classes(neighbours)
    chosen = np.full(lab.shape[0], -1, np.int64)
    for k in range(int(classes.max(initial=-1)) + 1):  # a loop over classes, not faces
        faces = np.flatnonzero(classes == k)
        distance = colour.delta_E(target[faces, None, :], filaments.lab[None], method="CIE 2000")
        pick = np.argmin(np.atleast_2d(distance), axis=1)
        chosen[faces] = pick
        around = neighbours[faces]  # (C, 3)
        later = (around >= 0) & (classes[np.maximum(around, 0)] > k)
        share = np.divide(1.0, later.sum(axis=1), out=np.zeros(len(faces)), where=later.any(1))
        error = (target[faces] - filaments.lab[pick]) * share[:, None]
        rows, slot = np.nonzero(later)
        np.add.at(target, around[rows, slot], error[rows])
    return chosen


@kernel
def _face_classes(neighbours: NDArray[np.int64]) -> NDArray[np.int64]:
    """Greedy colouring of the faces by index: the least class no earlier neighbour has."""
    classes = np.full(neighbours.shape[0], -1, np.int64)
    for face in range(neighbours.shape[0]):
        taken = 0
        for j in range(neighbours.shape[1]):
            n = neighbours[face, j]
            if n >= 0 and classes[n] >= 0:
                taken |= 1 << classes[n]
        k = 0
        while taken & (1 << k):
            k += 1
        classes[face] = k
    return classes
