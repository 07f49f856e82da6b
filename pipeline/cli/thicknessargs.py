"""The thickness options shared by ``thickness``, ``shells``, ``build`` and ``fdm``.

``--thickness-rule FILE`` loads a rule (:mod:`shellvox.thickness._rule`); without it the
default rule applies. ``--max-edge MM`` splits faces of mixed colour first
(:mod:`shellvox.thickness._face_split`). A command's constant ``--thickness`` is refused
together with a rule or ``--max-edge`` (:func:`shellvox.api.layer_thickness`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from shellvox.cli.choices import printers


def add_rule_arguments(parser: argparse.ArgumentParser, *, printer: bool = False) -> None:
    """Add ``--thickness-rule FILE`` and ``--max-edge MM`` (and ``--printer`` if asked)."""
    group = parser.add_argument_group("thickness rule")
    if printer:
        group.add_argument(
            "--printer",
            default="j750",
            metavar="NAME|FILE.toml",
            help=f"printer profile whose optics the optical rule uses; one of "
            f"{printers()} or a .toml file (default j750)",
        )
    group.add_argument(
        "--thickness-rule",
        type=Path,
        metavar="FILE",
        help="TOML rule for the per-face thickness (default: the built-in optical rule: "
        "each face's colour layer as deep as its colour needs to settle under the "
        "printer's optics)",
    )
    group.add_argument(
        "--max-edge",
        metavar="MM",
        help="split faces whose colour varies (spread at least the rule's split.min_spread_de00) "
        "until no edge is longer than MM, so the thickness can follow the texture",
    )
