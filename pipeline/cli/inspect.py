"""Verify a build against its manifest, summarise it and draw previews.

Every file the manifest lists must be there, a regular file, of the recorded size and
SHA-256; otherwise one line names the file and the fix (rebuild). Previews
(:mod:`shellvox.report._previews`) in DIR/preview/: sections through the coloured surface with a
voxel-scale inset, the outer colour layer from six sides, the layer-depth histogram and
the halftone.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inspect``'s arguments."""
    parser.add_argument("folder", type=Path, metavar="DIR", help="output folder of shellvox build")
    parser.add_argument("--no-preview", action="store_true", help="only print the summary")


def run(args: argparse.Namespace) -> int:
    """Verify the build against its manifest, print the summary, write DIR/preview/*.png."""
    from shellvox.api import inspect_build

    checked = inspect_build(args.folder, previews=not args.no_preview)
    for label, value in checked.rows:
        print(f"{label:<24} {value}")
    if not args.no_preview and "layers.tif" not in checked.manifest["files"]:
        print("no previews: the previews are drawn from the TIFF stacks (--format tiff)")
    for path in checked.previews:
        print(f"{path}")
    return 0
