"""Build the layered voxel stack (layers.tif, colour.tif, volume.vdb) of a coloured model."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from offset import METHODS
from pipeline.build import build_stack
from pipeline.build_config import BuildConfig
from pipeline.cli.loadargs import add_load_arguments, load_options
from pipeline.cli.values import parse_lengths
from pipeline.errors import InputError
from pipeline.loading import load_model
from voxel.printers import PRINTERS, parse_voxel_size, printer_voxel_mm


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``build``'s arguments."""
    add_load_arguments(parser)
    parser.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR", help="output folder"
    )
    grid = parser.add_mutually_exclusive_group()
    grid.add_argument(
        "--printer",
        choices=sorted(PRINTERS),
        help="printer voxel grid (default j750: 600 x 300 dpi, 27 um layers)",
    )
    grid.add_argument("--voxel-size", metavar="X,Y,Z", help="voxel size in mm instead of a printer")
    parser.add_argument(
        "--thickness",
        default="0.5,0.5",
        metavar="T1,T2,...",
        help="thickness of each shell band in mm, outside in (default 0.5,0.5)",
    )
    parser.add_argument(
        "--colour-layers",
        "--color-layers",
        dest="colour_layers",
        default="1",
        metavar="K1,K2,...",
        help="layers that take the surface colour (default 1, the outermost)",
    )
    parser.add_argument(
        "--layers",
        choices=("distance", "shells"),
        default="distance",
        help="layer of a voxel from its exact distance to the surface (default), "
        "or from the offset shells holding it",
    )
    parser.add_argument(
        "--shell-meshes",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also write the offset shells to DIR/shells/ (default: yes)",
    )
    parser.add_argument("--method", choices=METHODS, default="robust", help="offset construction")
    parser.add_argument("--alpha", action="store_true", help="write colour.tif as RGBA")
    parser.add_argument("--no-vdb", action="store_true", help="skip volume.vdb")
    parser.add_argument(
        "--slab-mb", type=float, default=512.0, help="working memory per slab (default 512)"
    )
    parser.add_argument(
        "--compression-level", type=int, default=6,
        help="zlib level of the TIFFs, 1..9 (default 6)",
    )
    parser.add_argument(
        "--workers", type=int, default=0,
        help="processes computing slabs (default 0: one per core)",
    )
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: only on a terminal)",
    )


def config_from_args(args: argparse.Namespace) -> BuildConfig:
    """Turn parsed arguments into a :class:`BuildConfig` (bad values raise InputError)."""
    try:
        if args.voxel_size is not None:
            voxel, printer = parse_voxel_size(args.voxel_size), None
        else:
            printer = args.printer or "j750"
            voxel = printer_voxel_mm(printer)
    except ValueError as error:
        raise InputError(
            "--voxel-size", str(error), "pass e.g. --voxel-size 0.05,0.05,0.03"
        ) from None
    thickness = parse_lengths("--thickness", args.thickness)
    try:
        colour_layers = tuple(int(k) for k in args.colour_layers.split(","))
    except ValueError:
        colour_layers = ()
    if not colour_layers or not all(1 <= k <= len(thickness) + 1 for k in colour_layers):
        raise InputError(
            "--colour-layers",
            f"expected layer numbers in 1..{len(thickness) + 1}, got {args.colour_layers!r}",
            "pass e.g. --colour-layers 1",
        )
    if (
        not 1 <= args.compression_level <= 9
        or not (math.isfinite(args.slab_mb) and args.slab_mb > 0)
        or args.workers < 0
    ):
        raise InputError(
            "--compression-level/--slab-mb/--workers",
            f"got {args.compression_level}, {args.slab_mb} and {args.workers}",
            "use a level in 1..9, a positive finite slab size in MB and 0 or more workers",
        )
    return BuildConfig(
        voxel_mm=voxel,
        printer=printer,
        thickness_mm=thickness,
        colour_layers=colour_layers,
        layer_rule=args.layers,
        shell_meshes=args.shell_meshes or args.layers == "shells",
        shell_method=args.method,
        alpha=args.alpha,
        write_vdb=not args.no_vdb,
        slab_mb=args.slab_mb,
        compression_level=args.compression_level,
        workers=args.workers,
    )


def run(args: argparse.Namespace) -> int:
    """Load the model, build the stack and print where the files are."""
    config = config_from_args(args)
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    started = time.perf_counter()
    mesh = load_model(args.model, load_options(args))
    load_seconds = time.perf_counter() - started
    manifest = build_stack(
        mesh, config, out, progress=args.progress, force=args.force, say=_say
    )
    manifest["seconds"]["load"] = load_seconds
    shape = " x ".join(str(n) for n in manifest["grid"]["shape_zyx"])
    print(f"{out}: grid {shape} (z, y, x) voxels")
    for name, record in manifest["files"].items():
        print(f"  {name}: {record['bytes']:,} bytes")
    print(json.dumps(manifest["voxel_counts"]))
    return 0


def _say(line: str) -> None:
    print(f"shellvox: {line}", file=sys.stderr)
