"""Parsing of option values shared by several subcommands."""

from __future__ import annotations

import math

from pipeline.errors import InputError


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
