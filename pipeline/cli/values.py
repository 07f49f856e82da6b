"""Parsing of option values shared by several subcommands."""

from __future__ import annotations

import math

from shellvox.errors import InputError


def parse_lengths(option: str, text: str, count: int | None = None) -> tuple[float, ...]:
    """Parse comma-separated positive lengths in mm, e.g. ``--thickness 0.4,0.6``.

    Parameters
    ----------
    option : str
        Option name, for the error message.
    text : str
        The value as typed.
    count : int, optional
        Exact number of values required.

    Raises
    ------
    InputError
        If a value is not a positive finite number or the count is wrong.
    """
    try:
        values = tuple(float(part) for part in text.replace(" ", "").split(","))
    except ValueError:
        values = ()
    ok = bool(values) and all(math.isfinite(v) and v > 0 for v in values)
    if not ok or (count is not None and len(values) != count):
        what = f"{count} " if count else ""
        raise InputError(
            option,
            f"expected {what}comma-separated positive lengths in mm, got {text!r}",
            f"pass e.g. {option} " + ",".join(["0.5"] * (count or 2)),
        )
    return values


def parse_voxel_size(text: str) -> tuple[float, float, float]:
    """Parse ``--voxel-size X,Y,Z`` (or one number for cubic voxels) in mm.

    Examples
    --------
    >>> parse_voxel_size("0.1,0.1,0.05")
    (0.1, 0.1, 0.05)
    >>> parse_voxel_size("0.2")
    (0.2, 0.2, 0.2)
    """
    parts = text.replace(" ", "").split(",")
    values = parse_lengths("--voxel-size", text, 3 if len(parts) == 3 else 1)
    if len(values) == 1:
        values = values * 3
    return (values[0], values[1], values[2])


def optional_length(option: str, text: str | None) -> float | None:
    """Parse one positive length in mm (:func:`parse_lengths`); None when not given."""
    return None if text is None else parse_lengths(option, text, 1)[0]
