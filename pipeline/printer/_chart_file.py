"""``chart.json`` read back and checked, and a chart's readings matched to its patches.

What ``shellvox calibrate`` needs from a chart (:func:`shellvox.printer._chart.chart_json`
writes it): the printer profile's TOML text, the optics the chart was made with (the
fit's start) and every patch's layers, top first, nothing beneath the last one.
Anything malformed is refused with one :class:`shellvox.errors.InputError` naming the
file and the patch or key.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn, TypeGuard

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError
from shellvox.printer._cgats import read_cgats
from shellvox.voxel.colour import Optics, Patch

#: How far a layer's fractions may sum from 1.
FRACTION_TOLERANCE = 1e-4
_FIX = "make the chart again with shellvox chart"


@dataclass(frozen=True, eq=False)
class ChartFile:
    """A chart read from ``chart.json``.

    Attributes
    ----------
    path : Path
    printer_name, printer_toml : str
        The profile the chart was made for, and its whole TOML text.
    optics : Optics
        The optics of the chart's profile (``assumed`` as recorded).
    patches : list of Patch
        Fractions in the order of ``optics.names``.
    """

    path: Path
    printer_name: str
    printer_toml: str
    optics: Optics
    patches: list[Patch]


def read_chart(path: str | Path) -> ChartFile:
    """Read and check ``chart.json`` (see the module); :class:`InputError` when malformed."""
    path = Path(path)

    def fail(problem: str) -> NoReturn:
        raise InputError(path, problem, _FIX)

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise InputError(path, f"cannot be read ({error.strerror})", "check the path") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        fail(f"is not JSON ({error})")
    if not isinstance(data, dict):
        fail("is not a chart (a JSON object with printer, optics and patches)")
    printer = data.get("printer")
    if not (isinstance(printer, dict) and isinstance(printer.get("toml"), str)):
        fail("has no printer.toml (the printer profile's text)")
    optics = _optics(data.get("optics"), fail)
    raw = data.get("patches")
    if not isinstance(raw, list) or not raw:
        fail("has no patches")
    patches, seen = [], set()
    for n, entry in enumerate(raw):  # loop over patches (tens)
        patch = _patch(entry, n, optics.names, fail)
        if patch.patch_id in seen:
            fail(f"patch {patch.patch_id!r} is listed twice")
        seen.add(patch.patch_id)
        patches.append(patch)
    return ChartFile(path, str(printer.get("name", "")), printer["toml"], optics, patches)


def _number(value: object) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _optics(raw: Any, fail: Callable[[str], NoReturn]) -> Optics:
    if not isinstance(raw, dict):
        fail("has no optics table")
    bands = raw.get("wavelengths_nm")
    if not (isinstance(bands, list) and len(bands) >= 3 and all(_number(v) for v in bands)):
        fail("optics.wavelengths_nm must be at least 3 numbers")
    b = len(bands)
    materials = raw.get("materials")
    if not isinstance(materials, list) or not materials:
        fail("optics.materials must list the materials")
    names, roles, k, s = [], [], [], []
    for i, m in enumerate(materials):
        ok = (
            isinstance(m, dict)
            and isinstance(m.get("name"), str)
            and isinstance(m.get("role"), str)
        )
        for key in ("k_per_mm", "s_per_mm"):
            values = m.get(key) if isinstance(m, dict) else None
            ok = ok and isinstance(values, list) and len(values) == b
            ok = ok and all(_number(v) and v >= 0 for v in values)  # type: ignore[union-attr]
        if not ok:
            fail(f"optics.materials[{i}] needs name, role and {b} k_per_mm and s_per_mm >= 0")
        names.append(m["name"])
        roles.append(m["role"])
        k.append(m["k_per_mm"])
        s.append(m["s_per_mm"])
    k1, k2 = raw.get("k1"), raw.get("k2")
    if not (_number(k1) and _number(k2) and 0 <= k1 < 1 and 0 <= k2 < 1):
        fail(f"optics.k1 and k2 must be in [0, 1), got {k1!r}, {k2!r}")
    return Optics(
        names=tuple(names),
        roles=tuple(roles),
        wavelengths_nm=np.asarray(bands, np.float64),
        k1=float(k1),
        k2=float(k2),
        k_per_mm=np.asarray(k, np.float64),
        s_per_mm=np.asarray(s, np.float64),
        assumed=bool(raw.get("assumed", True)),
    )


def _patch(entry: Any, n: int, names: tuple[str, ...], fail: Callable[[str], NoReturn]) -> Patch:
    patch_id = entry.get("id") if isinstance(entry, dict) else None
    if not isinstance(patch_id, str) or not patch_id.strip():
        fail(f"patch {n + 1} has no id")
    layers = entry.get("layers")
    if not isinstance(layers, list) or not layers:
        fail(f"patch {patch_id!r} has no layers")
    fractions = np.zeros((len(layers), len(names)))
    for j, item in enumerate(layers):
        shares = item.get("fractions") if isinstance(item, dict) else None
        t = item.get("thickness_mm") if isinstance(item, dict) else None
        if not isinstance(shares, dict) or not (_number(t) and t > 0):
            fail(f"patch {patch_id!r} layer {j + 1} needs fractions and a thickness_mm > 0")
        for name, share in shares.items():
            if name not in names:
                fail(
                    f"patch {patch_id!r} layer {j + 1} names {name!r}, not a material of the chart"
                )
            if not (_number(share) and share >= 0):
                fail(f"patch {patch_id!r} layer {j + 1} has share {share!r} of {name!r}")
            fractions[j, names.index(name)] = share
        if abs(fractions[j].sum() - 1.0) > FRACTION_TOLERANCE:
            fail(
                f"patch {patch_id!r} layer {j + 1}: fractions sum to {fractions[j].sum():g}, not 1"
            )
    fractions /= fractions.sum(axis=1, keepdims=True)
    return Patch(
        patch_id, fractions, np.array([item["thickness_mm"] for item in layers], np.float64)
    )


def chart_readings(chart: ChartFile, measured: str | Path) -> NDArray[np.float64]:
    """Return each patch's reading ``(N, B)`` at the chart optics' wavelengths.

    Raises
    ------
    InputError
        The file cannot be read (:class:`shellvox.printer._cgats.CgatsError`), a patch has
        no reading, or a reading names no patch of the chart (each named).
    """
    ids = [p.patch_id for p in chart.patches]
    readings = read_cgats(measured, expected_ids=ids)
    values = readings.at(chart.optics.wavelengths_nm, measured)
    row = {name: i for i, name in enumerate(readings.sample_ids)}
    known = set(ids)
    for name in readings.sample_ids:
        if name not in known:
            raise InputError(
                measured,
                f"sample {name!r} is not a patch of {chart.path.name}",
                "measure the chart made with it (ids in SAMPLE_ID or SAMPLE_NAME)",
            )
    for name in ids:
        if name not in row:
            raise InputError(measured, f"patch {name!r} has no reading", "measure every patch")
    return values[[row[name] for name in ids]]
