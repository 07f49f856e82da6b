"""Where each model of a tray goes: given positions, checked, or packed automatically.

Boxes are the models' axis-aligned bounding boxes (after scale and rotation). With
``--layout auto`` the footprints (x, y), each grown by the gap, are packed into the
printer's tray grown by the gap (rectpack's MaxRects, best short side fit, largest area
first, no turning), so packed boxes keep at least the gap between them and stay in the
tray; every model stands on the tray (z = 0). Given positions are checked: every box in
the tray, every pair at least the minimum gap apart along some axis. What does not fit
is refused before any work, naming each model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import rectpack
from numpy.typing import NDArray

from shellvox.errors import InputError, opt

#: How a tray is laid out: packed, as the tray file says, or each model where it is
#: (one model, no layout asked).
LayoutMode = Literal["auto", "given", "keep"]

#: Packing unit: footprints are packed in whole micrometres.
_UNITS_PER_MM = 1000

_FIX = f"use a smaller scale, fewer copies, or a printer with a larger tray ({opt('printer')})"


@dataclass(frozen=True)
class Layout:
    """Positions of a tray's models.

    Attributes
    ----------
    positions_mm : (N, 3) float64, mm
        Where each model's bounding-box minimum ``(x, y, z)`` goes.
    mode : {"auto", "given", "keep"}
        How they were chosen.
    gap_mm : float, mm
        The gap the packing kept (auto), or the minimum gap checked (given).
    """

    positions_mm: NDArray[np.float64]
    mode: LayoutMode
    gap_mm: float


def lay_out(
    names: Sequence[str],
    extents_mm: NDArray[np.float64],
    requested_mm: Sequence[tuple[float, float, float] | None],
    *,
    mode: LayoutMode,
    tray_mm: tuple[float, float, float],
    gap_mm: float,
    min_gap_mm: float,
    source: str = opt("tray"),
) -> Layout:
    """Return the positions of the models, or refuse a tray that does not fit.

    Parameters
    ----------
    names : sequence of str
        Each model's name in messages.
    extents_mm : (N, 3) float64, mm
        Size of each model's bounding box ``(x, y, z)``.
    requested_mm : sequence of (3,) float or None
        Given positions (``mode == "given"``: all needed); the minima for ``"keep"``.
    mode : {"auto", "given", "keep"}
        Pack, check the given positions, or keep the positions unchecked.
    tray_mm : (3,) float, mm
        The printer's tray ``(x, y, z)``.
    gap_mm : float, mm
        Gap between packed boxes (raised to `min_gap_mm`).
    min_gap_mm : float, mm
        The least gap the voxels need between two models.
    source : str
        Where given positions came from (named in messages).

    Raises
    ------
    InputError
        A model lacks a position, a box leaves the tray, two boxes are closer than
        `min_gap_mm`, or models do not fit the tray; one message names them all.
    """
    extents = np.asarray(extents_mm, dtype=np.float64).reshape(-1, 3)
    if mode == "auto":
        gap = max(gap_mm, min_gap_mm)
        return Layout(_pack(names, extents, tray_mm, gap), "auto", gap)
    missing = [name for name, p in zip(names, requested_mm, strict=True) if p is None]
    if missing:
        raise InputError(
            source,
            f"no position for {', '.join(missing)}",
            f"give each [[model]] a position = [x, y], or use {opt('layout', 'auto')}",
        )
    positions = np.array(requested_mm, dtype=np.float64).reshape(-1, 3)
    if mode == "keep":
        return Layout(positions, "keep", min_gap_mm)
    _check_given(names, extents, positions, tray_mm, min_gap_mm, source)
    return Layout(positions, "given", min_gap_mm)


def _pack(
    names: Sequence[str],
    extents: NDArray[np.float64],
    tray_mm: tuple[float, float, float],
    gap: float,
) -> NDArray[np.float64]:
    """Pack the footprints grown by `gap` into the tray grown by `gap` (see the module)."""
    tall = [name for name, e in zip(names, extents, strict=True) if e[2] > tray_mm[2]]
    if tall:
        raise InputError(
            opt("layout", "auto"),
            f"{', '.join(tall)} {'is' if len(tall) == 1 else 'are'} taller than the "
            f"tray's {tray_mm[2]:g} mm",
            _FIX,
        )
    size = np.ceil((extents[:, :2] + gap) * _UNITS_PER_MM).astype(np.int64)
    packer = rectpack.newPacker(
        mode=rectpack.PackingMode.Offline,
        pack_algo=rectpack.MaxRectsBssf,
        sort_algo=rectpack.SORT_AREA,
        rotation=False,
    )
    for index, (width, height) in enumerate(size):
        packer.add_rect(int(width), int(height), rid=index)
    bin_x, bin_y = (math.floor((t + gap) * _UNITS_PER_MM) for t in tray_mm[:2])
    packer.add_bin(bin_x, bin_y, count=1)
    packer.pack()
    positions = np.full((len(extents), 3), np.nan)
    for _, x, y, _, _, rid in packer.rect_list():
        positions[rid] = (x / _UNITS_PER_MM, y / _UNITS_PER_MM, 0.0)
    left = [name for name, p in zip(names, positions, strict=True) if np.isnan(p[0])]
    if left:
        raise InputError(
            opt("layout", "auto"),
            f"the {tray_mm[0]:g} x {tray_mm[1]:g} mm tray holds {len(names) - len(left)} of "
            f"the {len(names)} models with a {gap:g} mm gap; these do not fit: "
            f"{', '.join(left)}",
            _FIX,
        )
    return positions


def _check_given(
    names: Sequence[str],
    extents: NDArray[np.float64],
    positions: NDArray[np.float64],
    tray_mm: tuple[float, float, float],
    min_gap: float,
    source: str,
) -> None:
    """Refuse boxes outside the tray and pairs closer than `min_gap` (one message)."""
    tolerance = 1e-9
    upper = positions + extents
    outside = np.any(positions < -tolerance, axis=1) | np.any(
        upper > np.asarray(tray_mm) + tolerance, axis=1
    )
    problems = [
        f"{name} (at {_mm(p)}, {_mm(e)} mm) leaves the {_mm(np.asarray(tray_mm))} mm tray"
        for name, p, e, out in zip(names, positions, extents, outside, strict=True)
        if out
    ]
    # Two boxes are far enough apart when some axis separates them by min_gap.
    apart = np.any(
        (positions[:, None, :] >= upper[None, :, :] + min_gap - tolerance)
        | (positions[None, :, :] >= upper[:, None, :] + min_gap - tolerance),
        axis=2,
    )
    for a, b in np.argwhere(~apart):
        if a < b:
            problems.append(f"{names[a]} and {names[b]} are closer than {min_gap:.3g} mm")
    if problems:
        raise InputError(
            source,
            "; ".join(problems),
            f"move the models apart (at least {min_gap:.3g} mm: the deepest layer plus the "
            "level-set band) and into the tray, or " + _FIX,
        )


def _mm(values: NDArray[np.float64]) -> str:
    return " x ".join(f"{v:g}" for v in values)
