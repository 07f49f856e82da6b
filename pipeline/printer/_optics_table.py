"""A profile's optics: its ``[optics]`` table and each material's K and S, read and written.

.. code-block:: toml

    [optics]
    model = "kubelka-munk"            # the only model
    wavelengths_nm = [400.0, 410.0, ...]   # default 400-700 nm every 10 nm
    k1 = 0.04                         # Saunderson: external reflectance (n about 1.5)
    k2 = 0.6                          # internal reflectance of diffuse light
    # per [[materials]] (all printed materials or none):
    #   km_k_per_mm = [...]           # absorption per band, 1/mm (or one number: flat)
    #   km_s_per_mm = [...]           # scattering per band, 1/mm

A profile whose materials carry no ``km_k_per_mm`` and ``km_s_per_mm`` gets *assumed*
optics (:func:`shellvox.voxel.colour._optics.assumed_optics`: from the display colours and an
assumed scattering per role), recorded as assumed in the manifest and the report until a
printed, measured chart replaces them (``shellvox calibrate``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from shellvox.voxel.colour import K1_DEFAULT, K2_DEFAULT, WAVELENGTHS_NM, Optics, assumed_optics

#: Keys of the ``[optics]`` table.
OPTICS_KEYS = {"model", "wavelengths_nm", "k1", "k2"}

#: Per-material keys of the two-flux parameters.
MATERIAL_KEYS = ("km_k_per_mm", "km_s_per_mm")


class OpticsReader:
    """Read ``[optics]`` and the materials' K and S; `fail(key, problem, fix)` refuses."""

    def __init__(self, fail: Any) -> None:
        self.fail = fail

    def table(self, data: dict[str, Any]) -> tuple[np.ndarray[Any, Any], float, float]:
        """Return the bands, k1 and k2 of the ``[optics]`` table (defaults without one)."""
        table = data.get("optics", {})
        if not isinstance(table, dict):
            self.fail("optics", "must be a table", "write it as [optics]")
        unknown = sorted(set(table) - OPTICS_KEYS)
        if unknown:
            self.fail(f"optics.{unknown[0]}", "is not an optics key", f"use {sorted(OPTICS_KEYS)}")
        if table.get("model", "kubelka-munk") != "kubelka-munk":
            self.fail("optics.model", f"must be 'kubelka-munk', got {table['model']!r}", "fix it")
        bands = table.get("wavelengths_nm", WAVELENGTHS_NM.tolist())
        ok = isinstance(bands, list) and len(bands) >= 3 and all(_number(v) for v in bands)
        if not ok or not np.all(np.diff(np.asarray(bands, float)) > 0):
            self.fail(
                "optics.wavelengths_nm",
                f"must be at least 3 increasing wavelengths in nm, got {bands!r}",
                "give e.g. 400 to 700 every 10",
            )
        wavelengths = np.asarray(bands, np.float64)
        if wavelengths[0] < 360 or wavelengths[-1] > 830:
            self.fail("optics.wavelengths_nm", "must lie within 360-830 nm", "fix them")
        k1, k2 = table.get("k1", K1_DEFAULT), table.get("k2", K2_DEFAULT)
        for key, value in (("k1", k1), ("k2", k2)):
            if not (_number(value) and 0 <= value < 1):
                self.fail(f"optics.{key}", f"must be in [0, 1), got {value!r}", "fix it")
        return wavelengths, float(k1), float(k2)

    def spectrum(
        self, entry: dict[str, Any], key: str, prefix: str, n_bands: int
    ) -> np.ndarray[Any, Any] | None:
        """Return one material's K or S per band (a single number is flat), or None."""
        if key not in entry:
            return None
        value = entry[key]
        values = [value] if _number(value) else value
        ok = isinstance(values, list) and len(values) in (1, n_bands)
        if not ok or not all(_number(v) and v >= 0 for v in values):
            self.fail(
                prefix + key,
                f"must be a number >= 0 or {n_bands} of them (one per band), got {value!r}",
                "fix it",
            )
        return np.broadcast_to(np.asarray(values, np.float64), (n_bands,)).copy()


def profile_optics(
    reader: OpticsReader,
    data: dict[str, Any],
    entries: Sequence[dict[str, Any]],
    names: Sequence[str],
    roles: Sequence[str],
    display_srgb: Sequence[tuple[int, int, int]],
) -> Optics:
    """Return the optics of the printed materials (the void, entry 0, left out)."""
    wavelengths, k1, k2 = reader.table(data)
    n = len(wavelengths)
    spectra = [
        [reader.spectrum(e, key, f"materials[{i + 1}].", n) for key in MATERIAL_KEYS]
        for i, e in enumerate(entries)
    ]
    given = [k is not None and s is not None for k, s in spectra]
    if any(given) and not all(given):
        missing = given.index(False) + 1
        reader.fail(
            f"materials[{missing}].km_k_per_mm",
            "is missing while other materials have km_k_per_mm and km_s_per_mm",
            "give both for every printed material, or for none (assumed optics)",
        )
    if not any(given):
        return assumed_optics(names, roles, display_srgb, wavelengths_nm=wavelengths, k1=k1, k2=k2)
    k = np.array([ks[0] for ks in spectra])
    s = np.array([ks[1] for ks in spectra])
    return Optics(tuple(names), tuple(roles), wavelengths, k1, k2, k, s, assumed=False)


def optics_toml(optics: Optics) -> tuple[str, list[str]]:
    """Return the ``[optics]`` table and each material's K and S lines, as TOML text."""
    table = "\n".join(
        [
            "[optics]",
            'model = "kubelka-munk"',
            f"wavelengths_nm = {_list(optics.wavelengths_nm)}",
            f"k1 = {optics.k1!r}",
            f"k2 = {optics.k2!r}",
        ]
    )
    per_material = [
        f"km_k_per_mm = {_list(k)}\nkm_s_per_mm = {_list(s)}"
        for k, s in zip(optics.k_per_mm, optics.s_per_mm, strict=True)
    ]
    return table, per_material


def _list(values: np.ndarray[Any, Any]) -> str:
    return "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]"


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
