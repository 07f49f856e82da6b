"""Spectral readings from CGATS.17 text, as X-Rite i1Profiler and ArgyllCMS write it.

A CGATS file has keyword lines, a ``BEGIN_DATA_FORMAT`` ... ``END_DATA_FORMAT`` block
naming the fields and a ``BEGIN_DATA`` ... ``END_DATA`` block of rows (values separated
by white space, strings in double quotes). i1Profiler names spectral fields
``SPECTRAL_NM400`` (also ``nm400``), ArgyllCMS ``SPEC_400``; both carry ``SAMPLE_ID``
(``SampleID`` and ``SAMPLE_NAME`` are read too; i1Profiler keeps a sample's name in
``SAMPLE_NAME`` and a number in ``SampleID``: :func:`read_cgats` takes the id field that
matches the ids it is given). Reflectance is in percent (i1Profiler,
ArgyllCMS) or a fraction: a file whose largest value exceeds 1.5 is read as percent.
"""

from __future__ import annotations

import re
import shlex
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.errors import InputError

_SPECTRAL = re.compile(r"^(?:SPECTRAL_NM|SPECTRAL_|SPEC_|NM|R_)(\d{3})$", re.IGNORECASE)
_ID_FIELDS = ("SAMPLE_ID", "SAMPLEID", "SAMPLE_NAME")


class CgatsError(InputError):
    """A CGATS file that cannot be read: names the file, the problem and the fix."""


@dataclass(frozen=True)
class Readings:
    """Spectral readings of named samples.

    Attributes
    ----------
    sample_ids : tuple of str
    wavelengths_nm : (W,) float64, nm
    reflectance : (N, W) float64, fraction
    """

    sample_ids: tuple[str, ...]
    wavelengths_nm: NDArray[np.float64]
    reflectance: NDArray[np.float64]

    def at(self, wavelengths_nm: ArrayLike, path: str | Path) -> NDArray[np.float64]:
        """Return the readings ``(N, B)`` interpolated to `wavelengths_nm` (in range)."""
        wanted = np.asarray(wavelengths_nm, np.float64)
        lo, hi = self.wavelengths_nm.min(), self.wavelengths_nm.max()
        if wanted.min() < lo - 1e-9 or wanted.max() > hi + 1e-9:
            raise CgatsError(
                path,
                f"its spectra cover {lo:g}-{hi:g} nm, the model needs "
                f"{wanted.min():g}-{wanted.max():g} nm",
                "measure the chart over the model's wavelengths",
            )
        return np.stack([np.interp(wanted, self.wavelengths_nm, r) for r in self.reflectance])


def read_cgats(path: str | Path, *, expected_ids: Collection[str] = ()) -> Readings:
    """Read the spectral readings of a CGATS.17 file (see the module).

    Parameters
    ----------
    path : str or Path
    expected_ids : collection of str
        The sample ids wanted (a chart's patch ids). A file may carry several id fields
        (i1Profiler writes a number in ``SampleID`` and the name in ``SAMPLE_NAME``): the
        one holding most of `expected_ids` names the samples; without them (or a tie) the
        first of ``SAMPLE_ID``, ``SAMPLEID``, ``SAMPLE_NAME``.

    Raises
    ------
    CgatsError
        No data block, no sample id or spectral fields, a row of the wrong length, a
        non-numeric, NaN or negative value, a reading outside ``[0, 1.05]``, or a sample
        id given twice; each named with the sample.
    """
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as error:
        raise CgatsError(path, f"cannot be read ({error.strerror})", "check the path") from None
    fields, rows = _blocks(path, text)
    upper = [f.upper() for f in fields]
    id_columns = [upper.index(f) for f in _ID_FIELDS if f in upper]
    spectral = [(i, int(m.group(1))) for i, f in enumerate(fields) if (m := _SPECTRAL.match(f))]
    if not id_columns or not spectral:
        raise CgatsError(
            path,
            "has no SAMPLE_ID field or no spectral fields (SPECTRAL_NM400 ..., SPEC_400 ...)",
            "export spectral reflectance with sample ids",
        )
    wanted = set(expected_ids)

    def hits(column: int) -> int:
        return sum(len(row) > column and row[column] in wanted for row in rows)

    id_column = max(id_columns, key=hits)  # the first of the best (max keeps the first)
    ids: list[str] = []
    values = np.empty((len(rows), len(spectral)))
    for n, row in enumerate(rows):
        name = row[id_column] if len(row) > id_column else f"row {n + 1}"
        if len(row) != len(fields):
            raise CgatsError(
                path,
                f"sample {name!r} has {len(row)} values for {len(fields)} fields",
                "fix the row",
            )
        try:
            values[n] = [float(row[i]) for i, _ in spectral]
        except ValueError:
            raise CgatsError(
                path, f"sample {name!r} has a non-numeric reading", "fix the row"
            ) from None
        if name in ids:
            raise CgatsError(path, f"sample {name!r} is given twice", "keep one reading of it")
        ids.append(name)
    scale = 100.0 if np.nanmax(values, initial=0.0) > 1.5 else 1.0
    values /= scale
    bad = ~np.isfinite(values).all(1) | (values < 0).any(1) | (values > 1.05).any(1)
    if bad.any():
        name = ids[int(np.argmax(bad))]
        raise CgatsError(
            path,
            f"sample {name!r} has a reading that is NaN or outside [0, 1.05] "
            f"({'percent' if scale == 100 else 'fraction'})",
            "measure it again",
        )
    order = np.argsort([nm for _, nm in spectral])
    wavelengths = np.array([nm for _, nm in spectral], np.float64)[order]
    return Readings(tuple(ids), wavelengths, values[:, order])


def _blocks(path: str | Path, text: str) -> tuple[list[str], list[list[str]]]:
    """Return the field names and data rows of a CGATS text."""
    lines = text.splitlines()
    upper = [line.strip().upper() for line in lines]
    try:
        f0, f1 = upper.index("BEGIN_DATA_FORMAT"), upper.index("END_DATA_FORMAT")
        d0, d1 = upper.index("BEGIN_DATA"), upper.index("END_DATA")
    except ValueError:
        raise CgatsError(
            path,
            "is not CGATS text (no BEGIN_DATA_FORMAT ... END_DATA_FORMAT and "
            "BEGIN_DATA ... END_DATA blocks)",
            "export the readings as CGATS (i1Profiler, ArgyllCMS .ti3)",
        ) from None
    try:
        fields = shlex.split(" ".join(lines[f0 + 1 : f1]))
        rows = [shlex.split(line) for line in lines[d0 + 1 : d1] if line.strip()]
    except ValueError:
        raise CgatsError(path, "has an unclosed quote in its data", "fix the file") from None
    return fields, rows


def write_cgats(path: str | Path, readings: Readings, *, percent: bool = True) -> None:
    """Write `readings` as CGATS.17 text with ArgyllCMS's ``SPEC_`` fields."""
    nms = [round(float(w)) for w in readings.wavelengths_nm]
    scale = 100.0 if percent else 1.0
    lines = [
        "CGATS.17",
        'ORIGINATOR "shellvox"',
        f"NUMBER_OF_FIELDS {len(nms) + 1}",
        "BEGIN_DATA_FORMAT",
        "SAMPLE_ID " + " ".join(f"SPEC_{nm}" for nm in nms),
        "END_DATA_FORMAT",
        f"NUMBER_OF_SETS {len(readings.sample_ids)}",
        "BEGIN_DATA",
    ]
    for name, row in zip(readings.sample_ids, readings.reflectance, strict=True):
        lines.append(f'"{name}" ' + " ".join(f"{v * scale:.5f}" for v in row))
    lines.append("END_DATA")
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
