"""Build the layered voxel stack (layers.tif, colour.tif, volume.vdb) of a coloured model."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from shellvox.cli.buildargs import add_build_arguments, options_from_args
from shellvox.cli.loadargs import load_options
from shellvox.cli.runargs import running_from_args
from shellvox.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``build``'s arguments (:mod:`shellvox.cli.buildargs`)."""
    add_build_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Load the model(s), build the stack and print where the files are."""
    from shellvox.api import build

    if args.tray is not None and args.model:
        raise InputError("--tray", "was given with model files", "give model files or --tray")
    if args.tray is None and not args.model:
        raise InputError(None, "no model given", "give MODEL ... or --tray FILE.toml")
    one = args.tray is None and len(args.model) == 1 and args.copies == 1
    if not one or args.layout is not None or args.dry_run:
        return run_tray(args)
    options = options_from_args(args)  # bad options fail before loading
    running = running_from_args(args)
    started = time.perf_counter()
    result = build(
        args.model[0],
        args.output,
        options,
        load=load_options(args),
        running=running,
        progress=args.progress,
        force=args.force,
        say=_say,
    )
    _report(args.output, result.manifest, time.perf_counter() - started)
    return 0


def _report(out: Path, manifest: dict[str, Any], wall_seconds: float) -> None:
    """Print where the files are, the voxel counts, the colour report and the times."""
    from shellvox.output import file_summary
    from shellvox.stack import report_line

    shape = " x ".join(str(n) for n in manifest["grid"]["shape_zyx"])
    print(f"{out}: grid {shape} (z, y, x) voxels")
    for name, n_files, n_bytes in file_summary(manifest["files"]):
        files = f"{n_files:,} files, " if name.endswith("/") else ""
        print(f"  {name}: {files}{n_bytes:,} bytes")
    print(json.dumps(manifest["voxel_counts"]))
    line = report_line(manifest.get("colour_report"))
    if line is not None:
        print(line)
    built = manifest["seconds"]["total"]
    print(f"loaded in {max(0.0, wall_seconds - built):.1f} s, built in {built:.1f} s")


def run_tray(args: argparse.Namespace) -> int:
    """Plan a tray (several models, copies, a layout, or a dry run), then build it."""
    from shellvox.api import build_tray, plan_tray_build
    from shellvox.stack import resource_shortfall

    options = options_from_args(args)
    models = args.tray if args.tray is not None else args.model
    started = time.perf_counter()
    request = plan_tray_build(
        models,
        args.output,
        options,
        copies=args.copies,
        layout=args.layout,
        gap_mm=args.gap,
        load=load_options(args),
        force=args.force or args.dry_run,
    )
    plan = request.plan
    if args.dry_run:
        print("\n".join(plan.lines()))
        print(f"estimate: {plan.estimate.line()}")
        shortfall = None if args.force else resource_shortfall(plan.estimate, args.output)
        if shortfall is not None:
            print(f"a build would stop here: {shortfall.words('cli')}")
        print(f"planned in {request.seconds:.1f} s; dry run: nothing built")
        return 0
    print("\n".join(plan.lines()), file=sys.stderr)
    result = build_tray(
        request,
        args.output,
        running=running_from_args(args),
        progress=args.progress,
        force=args.force,
        say=_say,
    )
    _report(args.output, result.manifest, time.perf_counter() - started)
    return 0


def _say(line: str) -> None:
    print(f"shellvox: {line}", file=sys.stderr)
