"""Show a model's size, topology and colour source as read by shellvox.

An open, non-manifold or many-part model is reported as it is (exit 0); only a file that
is no model (unreadable, no faces) is refused (exit 2).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from shellvox.cli.loadargs import add_load_arguments, load_options


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``info``'s arguments."""
    add_load_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout")


def run(args: argparse.Namespace) -> int:
    """Print the summary of a model."""
    from shellvox.loading import load_model
    from shellvox.model import summarise

    summary = summarise(load_model(args.model, load_options(args), check="report"))
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
        ("unit", summary["unit"] or "-"),
        ("up", summary["up"] or "-"),
        ("closed", _closed(summary)),
        ("non-manifold", _non_manifold(summary)),
        ("orientation", _orientation(summary)),
        ("parts", _parts(summary)),
        ("overlapping parts", _pairs(summary["overlapping_parts"])),
        ("buried faces", f"{summary['buried_faces']:,}"),
        ("volume", _volume(summary)),
        ("colour", summary["colour"]),
        ("textures", textures),
        ("distinct colours", f"{summary['distinct_colours']:,}"),
    ]
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    return 0


def _at(point: list[float]) -> str:
    x, y, z = point
    return f"({x:.4g}, {y:.4g}, {z:.4g}) mm"


def _closed(summary: dict[str, Any]) -> str:
    """``yes``, or the boundary edges, holes and where the largest are."""
    if summary["closed"]:
        return "yes"
    if not summary["boundary_edges"]:
        return "no (see non-manifold)"
    where = "; ".join(f"{edges} edges at {_at(at)}" for at, edges in summary["holes_at_mm"])
    more = summary["holes"] - len(summary["holes_at_mm"])
    return (
        f"no: {summary['boundary_edges']:,} boundary edges in {summary['holes']:,} holes "
        f"({where}{f'; {more:,} more' if more > 0 else ''})"
    )


def _non_manifold(summary: dict[str, Any]) -> str:
    count = summary["non_manifold_edges"]
    if not count:
        return "none"
    where = _at(summary["non_manifold_at_mm"])
    return f"{count:,} edges shared by more than two faces, e.g. at {where}"


def _orientation(summary: dict[str, Any]) -> str:
    text = (
        "consistent"
        if summary["oriented"]
        else f"inconsistent: {summary['misoriented_edges']:,} edges have both faces running "
        "the same way"
    )
    inside_out = summary["inside_out_parts"]
    if inside_out:
        text += f"; inside out: {_numbers(inside_out)}"
    return text


def _parts(summary: dict[str, Any]) -> str:
    count, open_parts = summary["parts"], summary["open_parts"]
    return f"{count:,}" + (f" ({open_parts:,} open)" if open_parts else "")


def _numbers(parts: list[int]) -> str:
    shown = ", ".join(str(k) for k in parts[:10])
    return (
        ("part " if len(parts) == 1 else "parts ")
        + shown
        + (f" and {len(parts) - 10:,} more" if len(parts) > 10 else "")
    )


def _pairs(pairs: list[list[int]]) -> str:
    if not pairs:
        return "none"
    shown = ", ".join(f"{i} and {j}" for i, j in pairs[:10])
    return f"{len(pairs):,} pairs: parts {shown}" + (
        f" and {len(pairs) - 10:,} more" if len(pairs) > 10 else ""
    )


def _volume(summary: dict[str, Any]) -> str:
    if not summary["encloses_volume"]:
        return "none: encloses no volume (a sheet), cannot be built"
    volume = f"{summary['volume_mm3']:.3f} mm^3"
    return volume if summary["closed"] else volume + " (of the faces as they are; open)"
