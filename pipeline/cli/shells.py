"""Offset a model's faces inward into nested shells and report their quality."""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from offset import METHODS, offset_shells, shell_report
from pipeline import __version__
from pipeline.cli.loadargs import add_load_arguments, load_options
from pipeline.cli.values import parse_lengths
from pipeline.config import ShellConfig, as_json
from pipeline.errors import InputError
from pipeline.loading import load_model
from pipeline.shell_files import save_shells
from voxel.atomic import write_text_atomic


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``shells``' arguments."""
    add_load_arguments(parser)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="DIR",
        help="output folder for shell_1.ply ... and report.json",
    )
    parser.add_argument(
        "--thickness",
        default="0.5,0.5",
        metavar="T1,T2,...",
        help="thickness of each layer in mm, outside in (default 0.5,0.5)",
    )
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
    config = ShellConfig(
        thickness_mm=parse_lengths("--thickness", args.thickness),
        method=args.method,
        layer_height_mm=parse_lengths("--layer-height", str(args.layer_height), 1)[0],
    )
    mesh = load_model(args.model, load_options(args))
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    out.mkdir(parents=True, exist_ok=True)
    thickness = np.asarray(config.thickness_mm, dtype=np.float64)

    started = time.perf_counter()
    _say(f"offsetting {len(mesh.faces):,} faces into {len(thickness)} shells ({config.method})")
    shells = offset_shells(mesh.vertices, mesh.faces, thickness, method=config.method)
    offset_seconds = time.perf_counter() - started
    _say("cleaning, writing and reading back the shell files")
    written = save_shells(out, shells)
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
            [w.shell for w in written],
            baselines=not args.no_baselines,
            layer_height_mm=config.layer_height_mm,
        )
    )
    for layer, w in zip(report["layers"], written, strict=True):
        # The report's "shell" entry is measured on the file as read back; this is how
        # it was written.
        layer["file"] = {
            "path": w.path.name,
            "format": "binary_little_endian PLY, property double x/y/z",
            "bytes": w.path.stat().st_size,
            "cleaning": w.cleaning,
        }
    report["seconds"]["total"] = time.perf_counter() - started
    write_text_atomic(out / "report.json", json.dumps(report, indent=2))
    for w in written:
        print(f"{w.path}: {len(w.shell.faces):,} faces")
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
