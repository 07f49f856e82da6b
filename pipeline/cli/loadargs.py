"""The loader options shared by every command that reads a model."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from shellvox.cli.choices import MAX_FACES, UNITS, UP_AXES
from shellvox.errors import InputError

if TYPE_CHECKING:
    from shellvox.config import LoadOptions


def add_load_arguments(parser: argparse.ArgumentParser, *, many: bool = False) -> None:
    """Add ``MODEL`` and the loader options (``--units``, ``--scale``, ...) to a parser.

    With `many`, ``MODEL ...`` takes any number of files (a list, possibly empty).
    """
    parser.add_argument(
        "model",
        type=Path,
        nargs="*" if many else None,
        metavar="MODEL",
        help="model file: .obj .ply .glb .gltf .3mf .stl .off .wrl"
        + (" (several: one tray, see --tray)" if many else ""),
    )
    group = parser.add_argument_group("model loading")
    group.add_argument(
        "--units",
        choices=UNITS,
        help="unit of the file's coordinates (default mm; 3MF declares its own, glTF is in m)",
    )
    group.add_argument(
        "--scale",
        type=float,
        default=1.0,
        help="extra scale factor after unit conversion (default 1)",
    )
    group.add_argument(
        "--size",
        type=float,
        metavar="MM",
        help="scale the model uniformly so its longest side is MM mm, whatever its unit "
        "(a slicer's scale-to-fit; not with --scale)",
    )
    group.add_argument(
        "--up",
        choices=UP_AXES,
        help="the file's axis that points up, turned to +Z (default: y for glTF, z otherwise; "
        "a negative axis as --up=-y)",
    )
    group.add_argument(
        "--colour",
        "--color",
        dest="colour",
        metavar="R,G,B[,A]",
        help="colour (0-255) for a model without colour, or the fallback "
        "when a texture is missing (with a warning)",
    )
    group.add_argument(
        "--texture",
        type=Path,
        metavar="FILE",
        help="texture image for an OBJ whose MTL or map_Kd is missing (OBJ only)",
    )
    group.add_argument(
        "--repair",
        action="store_true",
        help="close small holes and fix winding (with a warning) instead of refusing the model",
    )
    group.add_argument(
        "--force",
        action="store_true",
        help="lift the loader's limits (faces, texture pixels, coordinates 1e6 mm from the "
        "origin) and read referenced files outside the model's folder (with a warning)",
    )
    group.add_argument(
        "--max-faces",
        type=int,
        default=MAX_FACES,
        metavar="N",
        help=f"the sane face limit (default {MAX_FACES:,})",
    )


def parse_colour(text: str) -> tuple[int, int, int, int]:
    """Parse ``R,G,B`` or ``R,G,B,A`` (0-255) into an RGBA tuple."""
    try:
        values = [int(v) for v in text.replace(" ", "").split(",")]
    except ValueError:
        values = []
    if len(values) not in (3, 4) or not all(0 <= v <= 255 for v in values):
        raise InputError(
            "--colour",
            f"expected R,G,B or R,G,B,A in 0-255, got {text!r}",
            "pass e.g. --colour 200,30,30",
        )
    if len(values) == 3:
        values.append(255)
    return (values[0], values[1], values[2], values[3])


def load_options(args: argparse.Namespace) -> LoadOptions:
    """Build :class:`LoadOptions` from parsed arguments."""
    from shellvox.config import LoadOptions

    return LoadOptions(
        units=args.units,
        scale=args.scale,
        size_mm=args.size,
        up=args.up,
        colour=None if args.colour is None else parse_colour(args.colour),
        texture=args.texture,
        repair=args.repair,
        force=args.force,
        max_faces=args.max_faces,
    )
