"""Build the layered voxel stack (layers.tif, colour.tif, volume.vdb) of a coloured model."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

from pipeline.build import build_stack, report_line, resource_shortfall
from pipeline.cli.buildargs import add_build_arguments, config_from_args
from pipeline.cli.loadargs import load_options
from pipeline.cli.runargs import running_from_args
from pipeline.cli.thicknessargs import choose_thickness
from pipeline.cli.values import parse_lengths
from pipeline.errors import InputError
from pipeline.loading import load_model
from pipeline.output import file_summary
from pipeline.printer import load_profile
from pipeline.tray import (
    LayoutMode,
    ThicknessSource,
    build_tray,
    load_tray,
    plan_tray,
    tray_from_inputs,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``build``'s arguments (:mod:`pipeline.cli.buildargs`)."""
    add_build_arguments(parser)


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
    choice = choose_thickness(
        args, mesh, constant, profile=profile, settings=settings, max_faces=options.max_faces
    )
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
        spec,
        options,
        base,
        out,
        tray_mm=profile.tray_mm,
        mode=mode,
        gap_mm=args.gap,
        default_thickness=ThicknessSource(constant, args.thickness_rule),
        colour_layers=colour_layers,
        force=args.force or args.dry_run,
    )
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
            rule_args,
            part.mesh,
            part.thickness.constant_mm,
            profile=profile,
            settings=base.material,
            max_faces=options.max_faces,
        )
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
        plan,
        config,
        out,
        meshes=meshes,
        thickness=thickness,
        faces=faces,
        profile=None if config.material is None else profile,
        progress=args.progress,
        force=args.force,
        say=_say,
        running=running_from_args(args),
    )
    _report(out, manifest, load_seconds)
    return 0


def _say(line: str) -> None:
    print(f"shellvox: {line}", file=sys.stderr)
