"""Frozen configuration objects; each serialises to the manifest with :func:`as_json`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

Unit = Literal["micron", "mm", "cm", "m", "inch", "foot"]

#: Millimetres per unit.
UNIT_MM: dict[str, float] = {
    "micron": 1e-3,
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "inch": 25.4,
    "foot": 304.8,
}


@dataclass(frozen=True)
class LoadOptions:
    """How to read a model; the same options on every command that reads one.

    Parameters
    ----------
    units : Unit or None
        Unit of the file's coordinates when the format does not declare one
        (default millimetres). A 3MF declares its own unit.
    scale : float
        Extra factor applied after unit conversion (``--scale``).
    colour : tuple of 4 int or None
        sRGB + alpha for a model without colour (``--colour``), or the fallback colour
        when a texture is missing (then with a warning).
    texture : Path or None
        Texture image to use when an OBJ has no MTL or its ``map_Kd`` is missing.
    repair : bool
        Close small holes and fix inconsistent winding (with a warning) instead of refusing.
    force : bool
        Lift the loader's limits (:attr:`max_faces`, the texture pixel budget, coordinates
        beyond 1e6 mm) and read referenced files outside the model's folder, with a
        warning (see :mod:`pipeline.loading`).
    max_faces : int
        Sane face limit without ``force``.
    """

    units: Unit | None = None
    scale: float = 1.0
    colour: tuple[int, int, int, int] | None = None
    texture: Path | None = None
    repair: bool = False
    force: bool = False
    max_faces: int = 5_000_000


def as_json(config: Any) -> dict[str, Any]:
    """Return a JSON-serialisable dict of a frozen config dataclass (paths as strings)."""

    def convert(value: Any) -> Any:
        if isinstance(value, Path):
            return str(value)
        if isinstance(value, tuple | list):
            return [convert(item) for item in value]
        if isinstance(value, dict):
            return {key: convert(item) for key, item in value.items()}
        return value

    return {key: convert(value) for key, value in dataclasses.asdict(config).items()}


@dataclass(frozen=True)
class ShellConfig:
    """How shells are made (``shellvox shells``; the shell stage of ``build``).

    Parameters
    ----------
    thickness_mm : tuple of float
        Thickness of each layer, outside in (mm), the same for every face (``--thickness``);
        empty when a thickness rule sets it per face.
    method : {"robust", "paper"}
        Offset construction (see :mod:`offset`).
    layer_height_mm : float
        Printer layer height used by the slicer baseline of the report.
    """

    thickness_mm: tuple[float, ...] = (0.5, 0.5)
    method: Literal["robust", "paper"] = "robust"
    layer_height_mm: float = 0.027
