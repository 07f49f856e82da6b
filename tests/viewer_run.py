"""Run the viewer's server on a build in a thread, for the viewer's tests."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from pipeline.viewer import BuildFolder, ViewerServer


@contextmanager
def serving(build: Path) -> Iterator[ViewerServer]:
    """Yield a :class:`ViewerServer` of `build` on a free port, stopped on exit."""
    viewer = ViewerServer(BuildFolder.open(build), 0)
    thread = threading.Thread(target=viewer.serve_forever, daemon=True)
    thread.start()
    try:
        yield viewer
    finally:
        viewer.shutdown()
        viewer.server_close()
        thread.join()
