"""Printer voxel grids: named profiles and a plain ``X,Y,Z`` voxel size."""

from __future__ import annotations

import math

MM_PER_INCH = 25.4

#: Voxel size ``(x, y, z)`` mm per printer profile. The Stratasys J750 / J8 Voxel Print grid
#: is 600 x 300 dpi with 27 um layers.
PRINTERS: dict[str, tuple[float, float, float]] = {
    "j750": (MM_PER_INCH / 600.0, MM_PER_INCH / 300.0, 0.027),
}


def printer_voxel_mm(name: str) -> tuple[float, float, float]:
    """Return the voxel size ``(x, y, z)`` mm of a printer profile.

    Examples
    --------
    >>> [round(v, 4) for v in printer_voxel_mm("j750")]
    [0.0423, 0.0847, 0.027]
    """
    try:
        return PRINTERS[name.lower()]
    except KeyError:
        raise ValueError(f"printer must be one of {sorted(PRINTERS)}, got {name!r}") from None


def parse_voxel_size(text: str) -> tuple[float, float, float]:
    """Parse ``"X,Y,Z"`` (or one number for cubic voxels) in mm.

    Examples
    --------
    >>> parse_voxel_size("0.1,0.1,0.05")
    (0.1, 0.1, 0.05)
    """
    parts = [part.strip() for part in text.split(",")]
    try:
        values = [float(part) for part in parts]
    except ValueError:
        raise ValueError(f"voxel size must be 'X,Y,Z' numbers in mm, got {text!r}") from None
    if len(values) == 1:
        values = values * 3
    if len(values) != 3 or not all(math.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"voxel size must be 1 or 3 positive numbers in mm, got {text!r}")
    return (values[0], values[1], values[2])
