"""The thickness options shared by ``thickness``, ``shells`` (and ``build``).

``--thickness-rule FILE`` loads a rule (:mod:`pipeline.thickness._rule`); without it the
default rule applies. ``--max-edge MM`` splits faces of mixed colour first
(:mod:`pipeline.thickness._face_split`). A command that also takes a constant ``--thickness`` passes
it to :func:`choose_thickness`, which refuses it together with a rule or ``--max-edge``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.cli.values import parse_lengths
from pipeline.config import MaterialSettings
from pipeline.errors import InputError
from pipeline.model import ColouredMesh
from pipeline.printer import PrinterProfile, build_material_plan, layer_model, shipped_profiles
from pipeline.thickness import (
    DEFAULT_RULE,
    FaceThickness,
    ThicknessRule,
    face_colour,
    face_thickness,
    load_rule,
    split_for_thickness,
)


def add_rule_arguments(parser: argparse.ArgumentParser, *, printer: bool = False) -> None:
    """Add ``--thickness-rule FILE`` and ``--max-edge MM`` (and ``--printer`` if asked)."""
    group = parser.add_argument_group("thickness rule")
    if printer:
        group.add_argument(
            "--printer",
            default="j750",
            metavar="NAME|FILE.toml",
            help=f"printer profile whose optics the optical rule uses; one of "
            f"{shipped_profiles()} or a .toml file (default j750)",
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


@dataclass(frozen=True, eq=False)
class ThicknessChoice:
    """The thickness a command uses, and the mesh it applies to.

    Attributes
    ----------
    mesh : ColouredMesh
        The model, split by ``--max-edge`` when asked.
    thickness_mm : (K, F) float64, mm
        Layer thickness per face (constant rows for ``--thickness``).
    faces : FaceThickness or None
        The rule's result (None for a constant ``--thickness``).
    source : str
        ``"--thickness"``, ``"default rule"`` or the rule file's path.
    """

    mesh: ColouredMesh
    thickness_mm: NDArray[np.float64]
    faces: FaceThickness | None
    source: str


def rule_from_args(args: argparse.Namespace) -> tuple[ThicknessRule, str]:
    """Return the rule the arguments ask for and where it came from."""
    path: Path | None = args.thickness_rule
    if path is None:
        return DEFAULT_RULE, "default rule"
    return load_rule(path), str(path)


def choose_thickness(
    args: argparse.Namespace,
    mesh: ColouredMesh,
    constant_mm: tuple[float, ...] | None = None,
    *,
    profile: PrinterProfile,
    settings: MaterialSettings | None = None,
    max_faces: int = 5_000_000,
) -> ThicknessChoice:
    """Apply ``--thickness`` (given as ``constant_mm``), or the rule and ``--max-edge``.

    The optical rule uses `profile`'s optics and the separation `settings` give
    (default: the profile's own materials).

    Raises
    ------
    InputError
        ``--thickness`` together with ``--thickness-rule`` or ``--max-edge``; a bad
        ``--max-edge``; a bad rule file.
    """
    if constant_mm is not None:
        for option, value in (
            ("--thickness-rule", args.thickness_rule),
            ("--max-edge", args.max_edge),
        ):
            if value is not None:
                raise InputError(
                    option,
                    "cannot be combined with --thickness (the same thickness on every face)",
                    f"drop --thickness to use a thickness rule, or drop {option}",
                )
        rows = np.repeat(np.asarray(constant_mm, np.float64)[:, None], mesh.n_faces, axis=1)
        return ThicknessChoice(mesh, rows, None, "--thickness")
    rule, source = rule_from_args(args)
    colour = None
    if args.max_edge is not None:
        max_edge = parse_lengths("--max-edge", args.max_edge, 1)[0]
        colour = face_colour(mesh)
        split = split_for_thickness(mesh, rule, max_edge, colour=colour, max_faces=max_faces)
        if split is not mesh:
            mesh, colour = split, None
    model = None
    if rule.rule == "optical":
        layers = rule.layers
        plan = build_material_plan(
            profile,
            settings or MaterialSettings(),
            colour_layers=layers.colour,
            n_bands=layers.n_layers,
        )
        model = layer_model(profile, plan, layers.backing_mm)
    faces = face_thickness(mesh, rule, colour=colour, model=model)
    return ThicknessChoice(mesh, faces.thickness_mm, faces, source)
