"""Offset a model's faces inward into nested shells and report their quality."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from shellvox.cli.choices import MAX_FIELD_TRIANGLES, SHELL_STEP_MM
from shellvox.cli.loadargs import add_load_arguments, load_options
from shellvox.cli.methodargs import add_method_argument
from shellvox.cli.thicknessargs import add_rule_arguments
from shellvox.cli.values import optional_length, parse_lengths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``shells``' arguments."""
    add_load_arguments(parser)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="DIR",
        help="output folder for shell_1.ply ..., report.json and (with a thickness rule) "
        "thickness.ply",
    )
    parser.add_argument(
        "--thickness",
        metavar="T1,T2,...",
        help="the same thickness on every face for each layer in mm, outside in "
        "(default: the per-face thickness of the thickness rule)",
    )
    add_rule_arguments(parser, printer=True)
    add_method_argument(parser, "the shells")
    parser.add_argument(
        "--shell-step",
        type=float,
        default=None,
        metavar="MM",
        help=f"grid step of the field method (default {SHELL_STEP_MM}: the depth error p99 about "
        "1.3 um on spot at 100 mm, raised where a large surface would give more than "
        f"{MAX_FIELD_TRIANGLES // 1_000_000} M triangles before simplification; halving it "
        "halves the error and quadruples the triangles)",
    )
    parser.add_argument(
        "--layer-height",
        type=float,
        default=0.027,
        metavar="MM",
        help="printer layer height for the slicer baseline (default 0.027)",
    )
    parser.add_argument(
        "--no-baselines",
        action="store_true",
        help="skip the vertex-normal and slicer baselines in the report",
    )


def run(args: argparse.Namespace) -> int:
    """Write the shells and their quality report."""
    from shellvox.api import write_shells
    from shellvox.config import ShellConfig

    constant = None if args.thickness is None else parse_lengths("--thickness", args.thickness)
    config = ShellConfig(
        thickness_mm=constant or (),
        method=args.method,
        step_mm=None
        if args.shell_step is None
        else parse_lengths("--shell-step", str(args.shell_step), 1)[0],
        layer_height_mm=parse_lengths("--layer-height", str(args.layer_height), 1)[0],
    )
    result = write_shells(
        args.model,
        args.output,
        config,
        thickness_rule=args.thickness_rule,
        max_edge_mm=optional_length("--max-edge", args.max_edge),
        printer=args.printer,
        baselines=not args.no_baselines,
        load=load_options(args),
        say=_say,
    )
    for layer, path in zip(result.report["layers"], result.files, strict=False):
        checks = layer["shell"]
        smallest = checks["min_angle_deg"]
        angle = "" if smallest is None else f", smallest angle {smallest:.2g} degrees"
        print(f"{path}: {checks['n_faces']:,} faces{angle}")
    for path in result.files[len(result.shells) :]:
        print(path)
    return 0


def _say(message: str) -> None:
    if sys.stderr.isatty():
        print(f"shellvox: {message}", file=sys.stderr)
