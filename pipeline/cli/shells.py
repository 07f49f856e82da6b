"""Offset a model's faces inward into nested shells and report their quality."""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import trimesh

from offset import METHODS, offset_shells, shell_report
from pipeline import __version__
from pipeline.cli.loadargs import add_load_arguments, load_options
from pipeline.cli.thicknessargs import add_rule_arguments, choose_thickness, write_thickness_ply
from pipeline.cli.values import parse_lengths
from pipeline.config import ShellConfig, as_json
from pipeline.errors import InputError
from pipeline.face_thickness import thickness_summary
from pipeline.loading import load_model
from voxel.atomic import atomic_path, write_text_atomic


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
    add_rule_arguments(parser)
    parser.add_argument(
        "--method",
        choices=METHODS,
        default="robust",
        help="offset construction (default robust; paper = the reference)",
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
    constant = None if args.thickness is None else parse_lengths("--thickness", args.thickness)
    config = ShellConfig(
        thickness_mm=constant or (),
        method=args.method,
        layer_height_mm=parse_lengths("--layer-height", str(args.layer_height), 1)[0],
    )
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    options = load_options(args)
    mesh = load_model(args.model, options)
    choice = choose_thickness(args, mesh, constant, max_faces=options.max_faces)
    mesh = choice.mesh
    thickness = choice.thickness_mm
    out.mkdir(parents=True, exist_ok=True)

    started = time.perf_counter()
    _say(f"offsetting {len(mesh.faces):,} faces into {len(thickness)} shells ({config.method})")
    shells = offset_shells(mesh.vertices, mesh.faces, thickness, method=config.method)
    offset_seconds = time.perf_counter() - started
    for shell in shells:
        with atomic_path(out / f"shell_{shell.layer}.ply") as temporary:
            ply = trimesh.Trimesh(shell.vertices, shell.faces, process=False)
            ply.export(str(temporary), file_type="ply")
    _say("measuring the shells" + ("" if args.no_baselines else " and the baselines"))
    report: dict[str, Any] = {
        "tool": f"shellvox {__version__}",
        "input": {"path": str(args.model), "sha256": _sha256(args.model)},
        "config": as_json(config),
        "seconds": {"offset": offset_seconds},
    }
    report.update(
        shell_report(
            mesh.vertices,
            mesh.faces,
            thickness,
            shells,
            baselines=not args.no_baselines,
            layer_height_mm=config.layer_height_mm,
        )
    )
    if choice.faces is not None:
        report["thickness"] = {"source": choice.source, **thickness_summary(choice.faces)}
        write_thickness_ply(out / "thickness.ply", mesh, choice.faces)
    report["seconds"]["total"] = time.perf_counter() - started
    write_text_atomic(out / "report.json", json.dumps(report, indent=2))
    for shell in shells:
        print(f"{out / f'shell_{shell.layer}.ply'}: {len(shell.faces):,} faces")
    if choice.faces is not None:
        print(f"{out / 'thickness.ply'}")
    print(f"{out / 'report.json'}")
    return 0


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _say(message: str) -> None:
    if sys.stderr.isatty():
        print(f"shellvox: {message}", file=sys.stderr)
