"""The options of ``build``: their definitions and the :class:`~shellvox.api.BuildOptions`."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

from shellvox.cli.choices import FORMATS, HALFTONES, LAYER_RULES, printers
from shellvox.cli.loadargs import add_load_arguments
from shellvox.cli.methodargs import add_method_argument
from shellvox.cli.runargs import add_running_arguments
from shellvox.cli.thicknessargs import add_rule_arguments
from shellvox.cli.values import optional_length, parse_lengths, parse_voxel_size
from shellvox.errors import InputError

if TYPE_CHECKING:
    from shellvox.api import BuildOptions


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
        help=f"printer profile: grid, materials, job format; one of {printers()} "
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
        "--backing",
        metavar="ROLE",
        help="material role of the backing layers (default: the profile's)",
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
        help="surface samples of the colour report and the soft proof, at least "
        "(default 20000; 0: no report, no proof)",
    )
    materials.add_argument(
        "--proof-density",
        type=float,
        default=12.0,
        metavar="N",
        help="surface samples per mm^2 of the soft proof, proof.ply (default 12: 0.29 mm "
        "apart; at most 250000 in all; 0: the report's samples only)",
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
        choices=LAYER_RULES,
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
    add_method_argument(parser, "the shell meshes")
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


def options_from_args(args: argparse.Namespace) -> BuildOptions:
    """Turn parsed arguments into :class:`~shellvox.api.BuildOptions` (bad values refused)."""
    from shellvox.api import BuildOptions
    from shellvox.config import MaterialSettings
    from shellvox.printer import load_profile

    formats = None
    if args.format != "auto":
        formats = tuple(part.strip() for part in args.format.split(",") if part.strip())
    colour_layers = None
    if args.colour_layers is not None:
        try:
            colour_layers = tuple(int(k) for k in args.colour_layers.split(","))
        except ValueError:
            raise InputError(
                "--colour-layers",
                f"expected layer numbers, got {args.colour_layers!r}",
                "pass e.g. 1 or 1,3",
            ) from None
    options = BuildOptions(
        printer=args.printer,
        voxel_size_mm=None if args.voxel_size is None else parse_voxel_size(args.voxel_size),
        formats=formats,
        thickness_mm=None
        if args.thickness is None
        else parse_lengths("--thickness", args.thickness),
        thickness_rule=args.thickness_rule,
        max_edge_mm=optional_length("--max-edge", args.max_edge),
        colour_layers=colour_layers,
        layer_rule=args.layers,
        shell_meshes=args.shell_meshes,
        shell_method=args.method,
        alpha=args.alpha,
        materials=None
        if args.no_materials
        else MaterialSettings(
            halftone=args.halftone,
            seed=args.seed,
            icc=args.icc,
            backing_role=args.backing,
            core_role=args.core,
        ),
        report_samples=args.report_samples,
        proof_density=args.proof_density,
        slab_mb=args.slab_mb,
        compression_level=args.compression_level,
        workers=args.workers,
    )
    if args.no_vdb:  # the formats asked for (or the default set) without volume.vdb
        chosen = options.chosen_formats(load_profile(args.printer))
        options = dataclasses.replace(options, formats=tuple(f for f in chosen if f != "vdb"))
    return options
