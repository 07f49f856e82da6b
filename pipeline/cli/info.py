"""Show a model's size, topology and colour source as read by shellvox."""

from __future__ import annotations

import argparse
import json

from shellvox.cli.loadargs import add_load_arguments, load_options


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``info``'s arguments."""
    add_load_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def run(args: argparse.Namespace) -> int:
    """Print the summary of a model."""
    from shellvox.loading import load_model
    from shellvox.model import summarise

    summary = summarise(load_model(args.model, load_options(args)))
    if args.json:
        print(json.dumps(summary))
        return 0
    (x0, y0, z0), (x1, y1, z1) = summary["bounds_mm"]
    sx, sy, sz = summary["size_mm"]
    textures = ", ".join(f"{w}x{h}" for w, h in summary["textures"]) or "-"
    rows = [
        ("model", summary["path"]),
        ("faces", f"{summary['faces']:,}"),
        ("vertices", f"{summary['vertices']:,}"),
        ("size", f"{sx:.3f} x {sy:.3f} x {sz:.3f} mm"),
        ("bounds", f"({x0:.3f}, {y0:.3f}, {z0:.3f}) .. ({x1:.3f}, {y1:.3f}, {z1:.3f}) mm"),
        ("closed", "yes" if summary["closed"] else "no"),
        ("oriented", "yes" if summary["oriented"] else "no"),
        ("volume", f"{summary['volume_mm3']:.3f} mm^3"),
        ("colour", summary["colour"]),
        ("textures", textures),
        ("distinct colours", f"{summary['distinct_colours']:,}"),
    ]
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    return 0
