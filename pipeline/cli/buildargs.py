"""The options of ``build``: their definitions and the :class:`BuildConfig` they make."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import get_args

import numpy as np

from pipeline.cli.loadargs import add_load_arguments
from pipeline.cli.runargs import add_running_arguments
from pipeline.cli.thicknessargs import ThicknessChoice, add_rule_arguments
from pipeline.cli.values import parse_lengths, parse_voxel_size
from pipeline.config import FORMATS, BuildConfig, MaterialSettings
from pipeline.errors import InputError
from pipeline.output import SHELL_METHODS
from pipeline.printer import PrinterProfile, load_profile, shipped_profiles
from voxel.colour import HALFTONES
from voxel.slab import LayerRule


def add_build_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``build``'s arguments (the loader's, the thickness rule's and the running ones too)."""
    add_load_arguments(parser, many=True)
    parser.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR", help="output folder"
    )
    tray = parser.add_argument_group("trays (several models, one job)")
    tray.add_argument(
        "--tray",
        type=Path,
        metavar="FILE.toml",
        help="the models of a tray: one [[model]] per model with file, position (x, y[, z] "
        "mm), rotation (x, y, z degrees), scale, thickness or thickness_rule, copies",
    )
    tray.add_argument(
        "--layout",
        choices=("auto", "given"),
        help="auto: pack the models into the printer's tray; given: the tray file's "
        "positions (default with --tray); several model files are packed",
    )
    tray.add_argument(
        "--gap",
        type=float,
        default=5.0,
        metavar="MM",
        help="gap between packed models (default 5; never less than the deepest layer plus "
        "the level-set band)",
    )
    tray.add_argument(
        "--copies", type=int, default=1, metavar="N", help="copies of each model file (packed)"
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="print the layout and the estimate (grid, voxels, memory, disk, time) and whether "
        "this machine would hold it; build nothing",
    )
    parser.add_argument(
        "--printer",
        default="j750",
        metavar="NAME|FILE.toml",
        help=f"printer profile: grid, materials, job format; one of {shipped_profiles()} "
        "or your own TOML file (default j750: 600 x 300 dpi, 27 um layers)",
    )
    parser.add_argument(
        "--voxel-size",
        metavar="X,Y,Z",
        help="voxel size in mm instead of the printer's grid (no printer job then)",
    )
    parser.add_argument(
        "--format",
        default="auto",
        metavar="F1,F2,...",
        help="files to write, among " + ",".join(FORMATS) + " (tiff: layers/colour/materials"
        ".tif, vdb: volume.vdb, gcvf: job.gcvf, png: slices/, zarr: stack.ome.zarr/, OME-Zarr "
        "with colour, materials and layers and their pyramids); default auto: tiff, zarr, vdb "
        "and the printer's job format when the grid is the printer's",
    )
    materials = parser.add_argument_group("materials (separation and halftone)")
    materials.add_argument(
        "--halftone",
        choices=HALFTONES,
        default="blue-noise",
        help="one material per voxel by a 3D blue-noise threshold (default, parallel) or "
        "3D error diffusion (in z order)",
    )
    materials.add_argument("--seed", type=int, default=0, help="halftone seed (default 0)")
    materials.add_argument(
        "--icc", type=Path, metavar="FILE", help="CMYK ICC output profile for the separation"
    )
    materials.add_argument(
        "--backing", metavar="ROLE", help="material role of the backing layers (default white)"
    )
    materials.add_argument(
        "--core", metavar="ROLE", help="material role of the core (default: the profile's)"
    )
    materials.add_argument(
        "--no-materials",
        action="store_true",
        help="skip materials: no materials.tif, job or colour report",
    )
    materials.add_argument(
        "--report-samples",
        type=int,
        default=20_000,
        metavar="N",
        help="surface samples of the colour report (default 20000; 0: no report)",
    )
    parser.add_argument(
        "--thickness",
        metavar="T1,T2,...",
        help="the same thickness on every face: each layer in mm, outside in (e.g. 0.5,0.5); "
        "default: the thickness rule (colour-adaptive per face)",
    )
    add_rule_arguments(parser)
    parser.add_argument(
        "--colour-layers",
        "--color-layers",
        dest="colour_layers",
        metavar="K1,K2,...",
        help="layers that take the surface colour (default: the rule's, or 1 with --thickness)",
    )
    parser.add_argument(
        "--layers",
        choices=get_args(LayerRule),
        default="distance",
        help="layer of a voxel from its exact distance to the surface (default), "
        "or from the offset shells holding it",
    )
    parser.add_argument(
        "--shell-meshes",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="also write the offset shells to DIR/shells/ (the shells of a large model take "
        "minutes, as the estimate says; `shellvox shells` makes them alone)",
    )
    parser.add_argument(
        "--method",
        choices=SHELL_METHODS,
        default="field",
        help="offset construction of the shells (default field; see `shellvox shells`)",
    )
    parser.add_argument(
        "--alpha",
        action="store_true",
        help="write colour.tif (and the OME-Zarr store's colour) as RGBA",
    )
    parser.add_argument("--no-vdb", action="store_true", help="skip volume.vdb (see --format)")
    parser.add_argument(
        "--slab-mb",
        type=float,
        default=1024.0,
        help="working memory per slab and worker (default 1024)",
    )
    parser.add_argument(
        "--compression-level",
        type=int,
        default=None,
        help="zlib level of the TIFFs, 1..9 (smaller files, slower); default: zlib-ng level 2",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=0,
        help="processes computing slabs (default 0: one per core)",
    )
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: only on a terminal)",
    )
    add_running_arguments(parser)


def config_from_args(
    args: argparse.Namespace,
    profile: PrinterProfile | None = None,
    choice: ThicknessChoice | None = None,
) -> BuildConfig:
    """Turn parsed arguments into a :class:`BuildConfig` (bad values raise InputError).

    `choice` is the thickness chosen for the model (:func:`choose_thickness`); without it
    ``--thickness`` must be given. :class:`BuildConfig` checks the values.
    """
    profile = profile or load_profile(args.printer)
    voxel = profile.voxel_mm
    if args.voxel_size is not None:
        voxel = parse_voxel_size(args.voxel_size)
    if choice is None or choice.faces is None:
        thickness = parse_lengths("--thickness", args.thickness or "0.5,0.5")
        default_colour = "1"
        source = "--thickness"
    else:
        thickness = tuple(float(np.median(row)) for row in choice.thickness_mm)
        default_colour = ",".join(str(k) for k in choice.faces.rule.layers.colour)
        source = choice.source
    text = args.colour_layers or default_colour
    try:
        colour_layers = tuple(int(k) for k in text.split(","))
    except ValueError:
        raise InputError(
            "--colour-layers", f"expected layer numbers, got {text!r}", "pass e.g. 1 or 1,3"
        ) from None
    return BuildConfig(
        voxel_mm=voxel,
        printer=profile.name,
        thickness_mm=thickness,
        thickness_source=source,
        colour_layers=colour_layers,
        layer_rule=args.layers,
        shell_meshes=args.shell_meshes,
        shell_method=args.method,
        alpha=args.alpha,
        formats=_formats(args, profile, voxel),
        material=None
        if args.no_materials
        else MaterialSettings(
            halftone=args.halftone,
            seed=args.seed,
            icc=args.icc,
            backing_role=args.backing,
            core_role=args.core,
        ),
        report_samples=args.report_samples,
        slab_mb=args.slab_mb,
        compression_level=args.compression_level,
        workers=args.workers,
    )


def _formats(
    args: argparse.Namespace, profile: PrinterProfile, voxel: tuple[float, float, float]
) -> tuple[str, ...]:
    """Return the formats to write (``--format``, ``--no-vdb``, the profile's job format)."""
    on_printer_grid = all(
        math.isclose(a, b, rel_tol=1e-9) for a, b in zip(voxel, profile.voxel_mm, strict=True)
    )
    if args.format == "auto":
        chosen = ["tiff", "zarr", "vdb"]
        if on_printer_grid and not args.no_materials:
            chosen.append(profile.slice_format)
    else:
        chosen = [part.strip() for part in args.format.split(",") if part.strip()]
        if "gcvf" in chosen and not on_printer_grid:
            raise InputError(
                "--format gcvf",
                f"a .gcvf job needs the printer's grid {profile.voxel_mm} mm, got "
                f"--voxel-size {voxel}",
                "drop --voxel-size or the gcvf format",
            )
        if args.no_materials and {"gcvf", "png"} & set(chosen):
            raise InputError("--format", "printer slices need materials", "drop --no-materials")
    if args.no_vdb and "vdb" in chosen:
        chosen.remove("vdb")
    return tuple(dict.fromkeys(chosen))  # unknown names: refused by BuildConfig
