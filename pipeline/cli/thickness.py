"""Show the per-face thickness a rule gives a model: a table, a picture and a PLY."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from shellvox.atomic import atomic_path, write_text_atomic
from shellvox.cli.loadargs import add_load_arguments, load_options
from shellvox.cli.thicknessargs import add_rule_arguments
from shellvox.cli.values import optional_length
from shellvox.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``thickness``' arguments."""
    add_load_arguments(parser)
    add_rule_arguments(parser, printer=True)
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="DIR",
        help="also write DIR/thickness.png (four views coloured by thickness), "
        "DIR/thickness.ply (per-face thickness) and DIR/thickness.json (the summary)",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace) -> int:
    """Print the thickness table; write the picture, PLY and summary when asked."""
    from shellvox.api import layer_thickness
    from shellvox.loading import load_model
    from shellvox.output import write_thickness_ply
    from shellvox.report import thickness_image
    from shellvox.thickness import thickness_summary

    out: Path | None = args.output
    if out is not None and out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", "choose another -o DIR")
    options = load_options(args)
    mesh = load_model(args.model, options)
    choice = layer_thickness(
        mesh,
        rule=args.thickness_rule,
        max_edge_mm=optional_length("--max-edge", args.max_edge),
        printer=args.printer,
        max_faces=options.max_faces,
    )
    faces = choice.faces
    assert faces is not None
    summary = thickness_summary(faces)
    summary["source"] = choice.source
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print("\n".join(table_lines(summary)))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        layer = faces.rule.colour_layer
        image = thickness_image(
            choice.mesh.vertices,
            choice.mesh.faces,
            faces.colour_layer_mm,
            value_range=(layer.min_mm, layer.max_mm),
            title=f"{args.model.name}: colour-layer thickness ({choice.source})",
        )
        with atomic_path(out / "thickness.png") as temporary:
            image.save(temporary, format="PNG")
        write_thickness_ply(out / "thickness.ply", choice.mesh, faces)
        write_text_atomic(out / "thickness.json", json.dumps(summary, indent=2))
        for name in ("thickness.png", "thickness.ply", "thickness.json"):
            print(out / name)
    return 0


def table_lines(summary: dict[str, Any]) -> list[str]:
    """Format :func:`shellvox.thickness._face_thickness.thickness_summary` as a text table."""
    colour = summary["colour_layer"]
    colour_layers = [str(layer["layer"]) for layer in summary["layers"] if layer["colour"]]
    lines = [
        f"colour layer {','.join(colour_layers)}: thickness in mm by face group "
        f"({summary['source']}; p50 weighted by area)",
        f"{'group':<14}{'faces':>9}{'area mm2':>12}{'min':>8}{'p50':>8}{'max':>8}",
    ]

    def row(name: str, group: dict[str, Any]) -> str:
        numbers = "".join(
            f"{'-' if group[key] is None else format(group[key], '.3f'):>8}"
            for key in ("min_mm", "p50_mm", "max_mm")
        )
        return f"{name:<14}{group['faces']:>9,}{group['area_mm2']:>12.1f}{numbers}"

    for name, group in colour["by_orientation"].items():
        lines.append(row(name, group))
    for group in colour["by_lightness"]:
        low, high = group["lightness"]
        lines.append(row(f"L* {low:g}-{high:g}", group))
    lines.append(row("alpha < 1", colour["translucent"]))
    for layer in summary["layers"]:
        if not layer["colour"]:
            lines.append(
                f"layer {layer['layer']} (backing): {layer['min_mm']:g}-{layer['max_mm']:g} mm"
            )
    spread = summary["colour_spread_de00"]
    limit = summary["rule"]["split"]["min_spread_de00"]
    lines.append(
        f"colour spread within faces (p90 CIEDE2000): p50 {spread['p50']:.1f}, "
        f"p90 {spread['p90']:.1f}, max {spread['max']:.1f}; {spread['faces_to_split']:,} "
        f"faces at {limit:g} or more (what --max-edge splits)"
    )
    lines.append(
        f"smoothing changed the colour layer by up to {colour['smoothing_change_mm']:.3f} mm; "
        f"the curvature cap binds on {colour['curvature_capped_faces']:,} faces"
    )
    optical = summary.get("optical")
    if optical is not None:
        settling = optical["settling_mm"]
        lines.append(
            f"optical rule: each face's colours settle within CIEDE2000 {optical['delta_e']:g} "
            f"at {settling['min_mm']:.3f}-{settling['max_mm']:.3f} mm (p50 "
            f"{settling['p50_mm']:.3f}; {optical['deepened_by_samples_faces']:,} faces deeper "
            f"than their robust colour needs, for a colour they cover); "
            f"{optical['not_settled_faces']:,} faces "
            f"({optical['not_settled_area_mm2']:.1f} mm2) still change at max_mm"
        )
    return lines
