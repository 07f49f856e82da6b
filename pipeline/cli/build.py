"""Build the layered voxel stack (layers.tif, colour.tif, volume.vdb) of a coloured model."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path
from typing import Any, get_args

import numpy as np

from pipeline.build import build_stack, report_line, resource_shortfall
from pipeline.cli.loadargs import add_load_arguments, load_options
from pipeline.cli.runargs import add_running_arguments, running_from_args
from pipeline.cli.thicknessargs import ThicknessChoice, add_rule_arguments, choose_thickness
from pipeline.cli.values import parse_lengths, parse_voxel_size
from pipeline.config import FORMATS, BuildConfig, MaterialSettings
from pipeline.errors import InputError
from pipeline.loading import load_model
from pipeline.output import SHELL_METHODS, file_summary
from pipeline.printer import PrinterProfile, load_profile, shipped_profiles
from pipeline.tray import (
    LayoutMode,
    ThicknessSource,
    build_tray,
    load_tray,
    plan_tray,
    tray_from_inputs,
)
from voxel.colour import HALFTONES
from voxel.slab import LayerRule


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``build``'s arguments."""
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
        "with colour, materials and layers and their pyramids); default auto: tiff, vdb and "
        "the printer's job format when the grid is the printer's",
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
        help="also write the offset shells to DIR/shells/ (the robust shells of a large "
        "model take minutes, as the estimate says; `shellvox shells` makes them alone)",
    )
    parser.add_argument(
        "--method",
        choices=SHELL_METHODS,
        default="robust",
        help="offset construction of the shells (default robust; see `shellvox shells`)",
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
        chosen = ["tiff", "vdb"]
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


def run(args: argparse.Namespace) -> int:
    """Load the model(s), build the stack and print where the files are."""
    if args.tray is not None and args.model:
        raise InputError("--tray", "was given with model files", "give model files or --tray")
    if args.tray is None and not args.model:
        raise InputError(None, "no model given", "give MODEL ... or --tray FILE.toml")
    one = args.tray is None and len(args.model) == 1 and args.copies == 1
    if not one or args.layout is not None or args.dry_run:
        return run_tray(args)
    profile = load_profile(args.printer)
    constant = None if args.thickness is None else parse_lengths("--thickness", args.thickness)
    settings = config_from_args(args, profile).material  # bad options fail before loading
    running = running_from_args(args)
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    started = time.perf_counter()
    options = load_options(args)
    mesh = load_model(args.model[0], options)
    choice = choose_thickness(args, mesh, constant, profile=profile, settings=settings,
                              max_faces=options.max_faces)  # fmt: skip
    config = config_from_args(args, profile, choice)
    load_seconds = time.perf_counter() - started
    manifest = build_stack(
        choice.mesh,
        config,
        out,
        thickness=choice.thickness_mm,
        faces=choice.faces,
        profile=None if config.material is None else profile,
        progress=args.progress,
        force=args.force,
        say=_say,
        running=running,
    )
    _report(out, manifest, load_seconds)
    return 0


def _report(out: Path, manifest: dict[str, Any], load_seconds: float) -> None:
    """Print where the files are, the voxel counts, the colour report and the times."""
    shape = " x ".join(str(n) for n in manifest["grid"]["shape_zyx"])
    print(f"{out}: grid {shape} (z, y, x) voxels")
    for name, n_files, n_bytes in file_summary(manifest["files"]):
        files = f"{n_files:,} files, " if name.endswith("/") else ""
        print(f"  {name}: {files}{n_bytes:,} bytes")
    print(json.dumps(manifest["voxel_counts"]))
    line = report_line(manifest.get("colour_report"))
    if line is not None:
        print(line)
    print(f"loaded in {load_seconds:.1f} s, built in {manifest['seconds']['total']:.1f} s")


def run_tray(args: argparse.Namespace) -> int:
    """Plan a tray (several models, copies, a layout, or a dry run), then build it."""
    profile = load_profile(args.printer)
    if args.tray is not None and args.copies != 1:
        raise InputError("--copies", "is for model files", "set copies in the tray file")
    if args.layers == "shells" or args.shell_meshes:
        raise InputError(
            "--layers shells" if args.layers == "shells" else "--shell-meshes",
            "a tray is built with distance layers and without shell meshes",
            "drop it; run `shellvox shells` on each model for its shells",
        )
    constant = None if args.thickness is None else parse_lengths("--thickness", args.thickness)
    if constant is not None and args.thickness_rule is not None:
        raise InputError(
            "--thickness-rule", "cannot be combined with --thickness", "drop one of them"
        )
    colour_layers = None
    if args.colour_layers is not None:
        colour_layers = config_from_args(args, profile).colour_layers  # checked there
    base = config_from_args(argparse.Namespace(**{**vars(args), "colour_layers": None}), profile)
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    started = time.perf_counter()
    spec = (
        load_tray(args.tray) if args.tray is not None else tray_from_inputs(args.model, args.copies)
    )
    options = load_options(args)
    mode: LayoutMode = args.layout or (
        "given" if args.tray is not None else "auto" if spec.n_instances > 1 else "keep"
    )
    plan = plan_tray(
        spec, options, base, out, tray_mm=profile.tray_mm, mode=mode, gap_mm=args.gap,
        default_thickness=ThicknessSource(constant, args.thickness_rule),
        colour_layers=colour_layers, force=args.force or args.dry_run,
    )  # fmt: skip
    if args.dry_run:
        print("\n".join(plan.lines()))
        print(f"estimate: {plan.estimate.line()}")
        shortfall = None if args.force else resource_shortfall(plan.estimate, out)
        if shortfall is not None:
            print(f"a build would stop here: {shortfall}")
        print(f"planned in {time.perf_counter() - started:.1f} s; dry run: nothing built")
        return 0
    print("\n".join(plan.lines()), file=sys.stderr)
    meshes, thickness, faces = [], [], []
    for part in plan.parts:
        rule_args = argparse.Namespace(
            thickness_rule=part.thickness.rule_path, max_edge=args.max_edge
        )
        choice = choose_thickness(
            rule_args, part.mesh, part.thickness.constant_mm, profile=profile,
            settings=base.material, max_faces=options.max_faces,
        )  # fmt: skip
        meshes.append(choice.mesh)
        thickness.append(choice.thickness_mm)
        faces.append(choice.faces)
    n_layers = plan.parts[0].n_layers
    config = dataclasses.replace(
        base,
        thickness_mm=(1.0,) * n_layers,  # set per face by build_tray
        colour_layers=plan.parts[0].colour_layers,
        shell_meshes=False,
    )
    load_seconds = time.perf_counter() - started
    manifest = build_tray(
        plan, config, out, meshes=meshes, thickness=thickness, faces=faces,
        profile=None if config.material is None else profile, progress=args.progress,
        force=args.force, say=_say, running=running_from_args(args),
    )  # fmt: skip
    _report(out, manifest, load_seconds)
    return 0


def _say(line: str) -> None:
    print(f"shellvox: {line}", file=sys.stderr)
