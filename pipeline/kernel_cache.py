"""The compiled kernels' cache on this machine: said once, when it is being filled.

shellvox's per-voxel loops are compiled by numba for the processor they run on
(:mod:`shellvox.voxel._compiled`), then kept in numba's cache beside the installed
modules. The first build after an installation or an upgrade compiles them; that is the
one wait that cannot be shipped. :func:`announce_compiling` makes it said: at the first
compilation in a process (numba's ``numba:compile`` event, fired on a cache miss only)
one line goes to stderr, unless a marker file for this shellvox, numba and Python says it
was said before (the slab workers compile too, at the same time: the marker is created
exclusively, so one of them says it).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

#: What the first compilation says (measured: about 20 s more than a warm build of the
#: default model on 2 cores, most of it in the slab workers, side by side).
NOTICE = (
    "shellvox: compiling its kernels for this machine, once (about half a minute); "
    "later runs load them from the cache"
)

_installed = False


def marker() -> Path:
    """Return the file that says the notice was given for this shellvox, numba and Python."""
    import numba

    from shellvox import __version__

    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    version = f"{sys.version_info.major}{sys.version_info.minor}"
    return Path(root) / "shellvox" / f"kernels-{__version__}-numba{numba.__version__}-py{version}"


def _claim(path: Path) -> bool:
    """Create `path` if it is not there; return whether this call created it."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644))
    except FileExistsError:
        return False
    except OSError:  # no cache folder to write: say it each time rather than never
        return True
    return True


def announce_compiling() -> None:
    """Say on stderr, once per machine and version, that the kernels are being compiled."""
    global _installed
    if _installed:
        return
    from numba.core import event

    class FirstCompile(event.Listener):
        said = False

        def on_start(self, _: Any) -> None:
            if not self.said:
                self.said = True
                if _claim(marker()):
                    print(NOTICE, file=sys.stderr, flush=True)

        def on_end(self, _: Any) -> None:
            """Nothing to do when a compilation ends."""

    event.register("numba:compile", FirstCompile())  # type: ignore[no-untyped-call]
    _installed = True
