"""The files shipped with shellvox: its default model and an example thickness rule.

Paths into the installed package (``importlib.resources``), so examples and tests run the
same from a checkout and from a wheel.

Examples
--------
>>> import shellvox
>>> shellvox.data.colour_target().name
'colour_target.obj'
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["colour_target", "thickness_rule"]


def colour_target() -> Path:
    """Return the default model: a 24 x 16 x 6 mm colour-target block (OBJ, MTL, PNG texture).

    Colour patches on every face (a lightness ramp, chroma ramps at several hues, a grey
    ramp) show what a per-face colour layer is for; ``make_colour_target.py`` beside it
    makes it, deterministically.
    """
    return Path(str(resources.files(__name__) / "colour_target" / "colour_target.obj"))


def thickness_rule() -> Path:
    """Return the example thickness rule (TOML): every key of the rule, with its default."""
    return Path(str(resources.files(__name__) / "thickness_rule.toml"))
