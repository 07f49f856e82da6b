"""A small G-code reader for the slicer tests: extrusion by tool, layer and position.

Reads what PrusaSlicer 2.5 writes with relative extrusion (``M83``): ``T<n>`` selects a
tool, ``G1`` moves with ``X``/``Y``/``Z``/``E``. Every extruding move is cut into pieces at
most ``step_mm`` long, each carrying its share of ``E`` at its midpoint, so a line that
runs through two regions is counted in both.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

_WORD = re.compile(r"([XYZEF])(-?\d*\.?\d+)")


@dataclass(frozen=True)
class Extrusion:
    """Extrusion pieces of a G-code file.

    Attributes
    ----------
    xy : (P, 2) float64, mm
        Midpoint of each piece.
    z : (P,) float64, mm
    tool : (P,) int64
    e : (P,) float64, mm of filament
    tool_changes : dict of float to int
        ``T`` commands per layer height (the first selection counts).
    """

    xy: NDArray[np.float64]
    z: NDArray[np.float64]
    tool: NDArray[np.int64]
    e: NDArray[np.float64]
    tool_changes: dict[float, int]


#: A move farther than this from the origin is off any printer's bed (mm): the slicer failed.
OFF_BED_MM = 2000.0


def read_extrusion(path: Path, *, step_mm: float = 0.2) -> Extrusion:
    """Read the extruding moves of a G-code file (relative E).

    Raises AssertionError naming the line at the first move off any bed (:data:`OFF_BED_MM`).
    """
    x = y = z = 0.0
    tool = -1
    pieces: list[tuple[float, float, float, int, float]] = []
    changes: dict[float, int] = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        line = line.split(";", 1)[0].strip()
        if not line:
            continue
        if line[0] == "T" and line[1:].isdigit():
            tool = int(line[1:])
            changes[z] = changes.get(z, 0) + 1
            continue
        if not (line.startswith("G1 ") or line.startswith("G0 ")):
            continue
        words = dict(_WORD.findall(line))
        nx, ny = float(words.get("X", x)), float(words.get("Y", y))
        z = float(words.get("Z", z))
        e = float(words.get("E", 0.0))
        if not (abs(nx) <= OFF_BED_MM and abs(ny) <= OFF_BED_MM):
            raise AssertionError(f"{path}:{number}: a move off any bed: {line}")
        if e > 0 and (nx, ny) != (x, y):
            n = max(1, int(np.ceil(np.hypot(nx - x, ny - y) / step_mm)))
            for k in range(n):
                t = (k + 0.5) / n
                pieces.append((x + t * (nx - x), y + t * (ny - y), z, tool, e / n))
        x, y = nx, ny
    data = np.array(pieces, np.float64).reshape(-1, 5)
    return Extrusion(
        xy=data[:, :2],
        z=data[:, 2],
        tool=data[:, 3].astype(np.int64),
        e=data[:, 4],
        tool_changes=changes,
    )
