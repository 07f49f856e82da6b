"""Thickness rules from TOML files (``--thickness-rule FILE``).

Every key and table is optional; missing keys keep the values of the rule's kind
(``rule = "optical"``, the default: :data:`shellvox.thickness._rule.DEFAULT_RULE`;
``rule = "lightness"``: :data:`shellvox.thickness._rule.LIGHTNESS_RULE`; what they mean,
and why the defaults: :mod:`shellvox.thickness._rule`). A file that cannot be read, or
holds an unknown table or key, a wrong type or a value out of range, is refused with the
file, the key and what to write.

TOML layout (every key optional; missing keys keep the default of the rule's kind)::

    rule = "optical"  # or "lightness"

    [colour_layer]
    min_mm = 0.3
    max_mm = 3.0
    delta_e = 1.0  # the optical rule: CIEDE2000 within which a colour has settled
    lightness_weight = 0.6  # the lightness rule's weights
    neutral_weight = 0.2
    transparency_weight = 0.2
    full_chroma = 100.0

    [orientation]
    upper_factor = 1.0
    side_factor = 1.0
    lower_factor = 1.0
    upper_min_normal_z = 0.5
    lower_max_normal_z = -0.05

    [curvature]
    max_depth_per_radius = 0.5  # 0 turns the cap off
    radius_mm = 1.0

    [smoothing]
    radius_mm = 1.0  # over this much surface; 0 turns it off

    [layers]
    colour = [1]  # which shell layers (1..K) are colour layers
    backing_mm = [0.5]  # the other layers, outside in; K = len(colour) + len(backing_mm)

    [split]
    min_spread_de00 = 5.0
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

from shellvox.errors import InputError
from shellvox.thickness._rule import (
    DEFAULT_RULE,
    LIGHTNESS_RULE,
    ColourLayerRule,
    CurvatureRule,
    LayersRule,
    OrientationRule,
    RuleError,
    SmoothingRule,
    SplitRule,
    ThicknessRule,
)

#: TOML table name -> the dataclass it fills.
_TABLES: dict[str, type[Any]] = {
    "colour_layer": ColourLayerRule,
    "orientation": OrientationRule,
    "curvature": CurvatureRule,
    "smoothing": SmoothingRule,
    "layers": LayersRule,
    "split": SplitRule,
}


def load_rule(path: str | Path) -> ThicknessRule:
    """Read a thickness rule from a TOML file; missing keys keep the default.

    Parameters
    ----------
    path : str or Path
        TOML file with the tables of the module docstring.

    Returns
    -------
    ThicknessRule

    Raises
    ------
    InputError
        Unreadable file, TOML syntax error, unknown table or key, wrong type or value out
        of range; the message names the file and the key and says what to write.

    Examples
    --------
    >>> import shellvox
    >>> rule = shellvox.load_rule(shellvox.data.thickness_rule())
    >>> rule.layers.colour, rule.layers.backing_mm
    ((1,), (0.5,))
    """
    path = Path(path)
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(path, "thickness rule file not found", "check the path") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(
            path, f"cannot read the thickness rule ({error})", "check the file"
        ) from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(
            path, f"is not valid TOML ({error})", "fix the syntax (see https://toml.io)"
        ) from None
    return rule_from_dict(document, path)


def rule_from_dict(document: dict[str, Any], path: str | Path | None = None) -> ThicknessRule:
    """Build a rule from a parsed TOML document (see :func:`load_rule`)."""
    where = path if path is not None else "thickness rule"
    kind = document.get("rule", "optical")
    if kind not in ("optical", "lightness"):
        raise InputError(
            where, f"rule must be 'optical' or 'lightness', got {kind!r}", 'write rule = "optical"'
        )
    base = DEFAULT_RULE if kind == "optical" else LIGHTNESS_RULE
    parts: dict[str, Any] = {}
    for table, values in document.items():
        if table == "rule":
            continue
        if table == "smoothing" and isinstance(values, dict) and "iterations" in values:
            raise InputError(
                where,
                "smoothing.iterations is no longer read: the colour layer is smoothed over a "
                "surface distance",
                "write radius_mm = 1.0 in [smoothing] (0 turns the smoothing off)",
            )
        if table not in _TABLES:
            raise InputError(
                where,
                f"unknown table [{table}]",
                f"use only {', '.join(f'[{name}]' for name in _TABLES)}",
            )
        if not isinstance(values, dict):
            raise InputError(where, f"{table} must be a table, got {values!r}", f"write [{table}]")
        part = _TABLES[table]
        known = {f.name: f for f in dataclasses.fields(part)}
        converted: dict[str, Any] = {}
        for key, value in values.items():
            if key not in known:
                raise InputError(
                    where,
                    f"unknown key {table}.{key}",
                    f"use only {', '.join(f'{table}.{name}' for name in known)}",
                )
            default = getattr(part(), key)
            if isinstance(default, tuple):
                if not isinstance(value, list):
                    raise InputError(
                        where,
                        f"{table}.{key} must be a list, got {value!r}",
                        f"write e.g. {key} = {list(default)!r}",
                    )
                value = tuple(value)
            elif isinstance(default, float) and isinstance(value, int):
                value = float(value) if not isinstance(value, bool) else value
            converted[key] = value
        try:
            parts[table] = dataclasses.replace(getattr(base, table), **converted)
        except RuleError as error:
            raise InputError(where, f"{error.key} {error.problem}", error.fix) from None
    return dataclasses.replace(base, **parts)
