"""Write a colour-skin 3MF project per FDM slicer (PrusaSlicer, Bambu Studio / OrcaSlicer)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from shellvox.cli.choices import SLICERS
from shellvox.cli.loadargs import add_load_arguments, load_options
from shellvox.cli.methodargs import add_method_argument
from shellvox.cli.thicknessargs import add_rule_arguments
from shellvox.cli.values import optional_length, parse_lengths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``fdm``'s arguments."""
    add_load_arguments(parser)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="DIR",
        help="output folder for <stem>_prusa.3mf and <stem>_bambu.3mf",
    )
    parser.add_argument(
        "--filaments",
        required=True,
        metavar="#RRGGBB,#RRGGBB,...",
        help="filament colours, the core's first (at least two)",
    )
    parser.add_argument(
        "--thickness",
        metavar="MM",
        help="the skin's depth on every face in mm (default: the colour layer of the "
        "thickness rule, raised to one extrusion width where thinner)",
    )
    add_rule_arguments(parser, printer=True)
    add_method_argument(parser, "the core")
    parser.add_argument(
        "--slicer",
        default=",".join(SLICERS),
        metavar="prusa,bambu",
        help="which projects to write (default both)",
    )
    parser.add_argument(
        "--layer-height", default="0.2", metavar="MM", help="layer height (default 0.2)"
    )
    parser.add_argument("--nozzle", default="0.4", metavar="MM", help="nozzle width (default 0.4)")
    parser.add_argument(
        "--dither",
        action="store_true",
        help="dither the filament choice over neighbouring faces (error diffusion)",
    )


def run(args: argparse.Namespace) -> int:
    """Write the projects and print a summary."""
    import numpy as np

    from shellvox.api import fdm_projects
    from shellvox.fdm import FdmSettings, check_slicers, parse_filaments
    from shellvox.fdm._project import check_filament_count

    started = time.perf_counter()
    filaments = parse_filaments(args.filaments)
    slicers = check_slicers(args.slicer.replace(" ", "").split(","))
    check_filament_count(filaments, slicers)  # refused before any work
    constant = None if args.thickness is None else parse_lengths("--thickness", args.thickness, 1)
    settings = FdmSettings(
        layer_height_mm=parse_lengths("--layer-height", args.layer_height, 1)[0],
        nozzle_mm=parse_lengths("--nozzle", args.nozzle, 1)[0],
    )
    result = fdm_projects(
        args.model,
        args.output,
        filaments,
        settings=settings,
        slicers=slicers,
        thickness_mm=None if constant is None else constant[0],
        thickness_rule=args.thickness_rule,
        max_edge_mm=optional_length("--max-edge", args.max_edge),
        printer=args.printer,
        method=args.method,
        dither=args.dither,
        load=load_options(args),
    )
    project = result.project
    counts = np.bincount(project.face_filament, minlength=len(filaments))
    shares = ", ".join(f"{h} {c:,}" for h, c in zip(filaments.hex, counts, strict=True))
    depth = project.depth_mm
    print(
        f"faces per filament: {shares}; skin depth {depth.min():.3g}-{depth.max():.3g} mm; "
        f"{len(project.parts)} volumes; {time.perf_counter() - started:.1f} s"
    )
    for path in result.files:
        print(path)
    return 0
