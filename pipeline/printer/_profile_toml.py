"""A printer profile's TOML text: read from where it came from, written with new optics.

:func:`profile_with_optics` writes the whole profile (every key of the original, its
materials in order) with the ``[optics]`` table and each printed material's
``km_k_per_mm`` and ``km_s_per_mm`` of the given optics, as TOML that :mod:`tomllib` and
:func:`shellvox.printer._profile.parse_profile` read back. Comments of the original are
not kept (a header says where the profile came from).
"""

from __future__ import annotations

import json
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from shellvox.errors import InputError
from shellvox.printer._optics_table import MATERIAL_KEYS, optics_toml
from shellvox.voxel.colour import Optics


def profile_text(name_or_path: str | Path) -> str:
    """Return the TOML text of a shipped profile name or a profile file."""
    path = Path(name_or_path)
    if path.is_file():
        return path.read_text(encoding="utf-8")
    shipped = resources.files("shellvox.printer") / "profiles" / f"{str(name_or_path).lower()}.toml"
    return shipped.read_text(encoding="utf-8")


def profile_with_optics(text: str, optics: Optics, *, header: str = "") -> str:
    """Return the profile in TOML `text` with `optics` in place of its own.

    Raises
    ------
    InputError
        When `text` is not TOML or its printed materials are not those of `optics`.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InputError(
            None, f"the chart's printer profile is not TOML ({error})", "make the chart again"
        ) from None
    materials = data.get("materials")
    if not isinstance(materials, list):
        materials = []
    names = [m.get("name") for m in materials[1:] if isinstance(m, dict)]
    if names != list(optics.names):
        raise InputError(
            None,
            f"the chart's profile has materials {names}, its optics {list(optics.names)}",
            "make the chart again",
        )
    table, per_material = optics_toml(optics)
    lines = [f"# {line}" for line in header.splitlines()]
    for key, value in data.items():
        if key not in ("materials", "optics"):
            lines.append(f"{key} = {_value(value)}")
    lines += ["", table]
    for index, entry in enumerate(materials):
        lines += ["", "[[materials]]"]
        lines += [f"{k} = {_value(v)}" for k, v in entry.items() if k not in MATERIAL_KEYS]
        if index > 0:
            lines.append(per_material[index - 1])
    return "\n".join(lines) + "\n"


def _value(value: Any) -> str:
    """TOML text of a scalar or a list of scalars (what profiles hold outside tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise InputError(
        None,
        f"the profile holds a value TOML text is not written for: {value!r}",
        "simplify the profile",
    )
