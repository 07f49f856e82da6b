"""Show a build's slices in the browser: a local web server on 127.0.0.1 (Ctrl-C stops it).

The page slices along z, y and x at the voxels' true size, zooms to single voxels, shows
colour, layers, materials, depth and per-face thickness, and reads out a clicked voxel
(:mod:`shellvox.viewer`). A folder that is not a complete build is refused.
"""

from __future__ import annotations

import argparse
import errno
import sys
import webbrowser
from pathlib import Path

from shellvox.errors import InputError
from shellvox.faults import Interrupted


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``view``'s arguments."""
    parser.add_argument("folder", type=Path, metavar="DIR", help="output folder of shellvox build")
    parser.add_argument(
        "--port", type=int, default=0, help="TCP port on 127.0.0.1 (default: a free one)"
    )
    parser.add_argument("--open", action="store_true", help="open the page in the web browser")


def run(args: argparse.Namespace) -> int:
    """Open the build, serve it until interrupted; return 0."""
    from shellvox.viewer import BuildFolder, ViewerServer

    if not 0 <= args.port <= 65535:
        raise InputError("--port", f"must be 0..65535, got {args.port}", "give a port number")
    folder = BuildFolder.open(args.folder)
    try:
        server = ViewerServer(folder, args.port)
    except OSError as error:
        folder.close()
        if error.errno in (errno.EADDRINUSE, errno.EACCES):
            raise InputError(
                "--port",
                f"port {args.port} cannot be used ({error.strerror})",
                "give another --port, or none for a free one",
            ) from None
        raise
    print(f"shellvox view: {folder.root} at {server.url} (Ctrl-C stops)", flush=True)
    if args.open:
        webbrowser.open(server.url)
    try:
        server.serve_forever()
    except (Interrupted, KeyboardInterrupt):
        print("shellvox view: stopped", file=sys.stderr)
    finally:
        server.server_close()
    return 0
