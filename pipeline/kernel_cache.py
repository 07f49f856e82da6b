"""The compiled kernels' cache: said once, when it is being filled.

shellvox's per-voxel loops are compiled by numba for the processor they run on
(:mod:`shellvox.voxel._compiled`), then kept in numba's cache: beside the installed
modules (their ``__pycache__`` folders), or under ``NUMBA_CACHE_DIR`` when it is set. The
first build with an empty cache (a new environment, an upgrade, a new
``NUMBA_CACHE_DIR``) compiles them; that is the one wait that cannot be shipped.
:func:`announce_compiling` makes it said: numba's ``numba:compile`` event fires on a cache
miss only, and at the first one of a shellvox kernel in a process one line goes to stderr,
unless the cache folder that kernel is compiled into holds the marker of this shellvox,
numba and Python (the slab workers compile too, at the same time: the marker is created
exclusively, so one of them says it). The marker lives in the cache it speaks of, so
another environment's cache, or another marker elsewhere, never silences it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

#: What the first compilation says (most of the compiling is in the slab workers, side
#: by side).
NOTICE = (
    "shellvox: compiling its kernels for this machine, once (about a minute on 2 cores); "
    "later runs load them from the cache"
)

_installed = False


def marker(cache: str | Path) -> Path:
    """Return the file in numba's cache folder `cache` that says the notice was given there.

    Parameters
    ----------
    cache : str or Path
        The folder numba writes a kernel's ``.nbi``/``.nbc`` files to (its dispatcher's
        ``_cache.cache_path``).

    Returns
    -------
    Path
        ``shellvox-kernels-VERSION-numbaVERSION-pyXY.said`` in that folder.
    """
    import numba

    from shellvox import __version__

    version = f"{sys.version_info.major}{sys.version_info.minor}"
    name = f"shellvox-kernels-{__version__}-numba{numba.__version__}-py{version}.said"
    return Path(cache) / name


def _cache_folder(data: Any) -> str | None:
    """Return the cache folder of the kernel a ``numba:compile`` event compiles; None: not ours.

    Only shellvox's kernels count (a caller's own numba functions compile unsaid), and
    only those numba caches on disk (all of shellvox's:
    :data:`~shellvox.voxel._compiled.KERNEL_OPTIONS`).
    """
    dispatcher = data.get("dispatcher") if isinstance(data, dict) else None
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", None) or ""
    if module != "shellvox" and not module.startswith("shellvox."):
        return None
    folder = getattr(getattr(dispatcher, "_cache", None), "cache_path", None)
    return folder if isinstance(folder, str) else None


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
    """Say on stderr, once per cache and version, that the kernels are being compiled."""
    global _installed
    if _installed:
        return
    from numba.core import event

    class FirstCompile(event.Listener):
        said = False

        def on_start(self, started: Any) -> None:
            if self.said:
                return
            folder = _cache_folder(started.data)
            if folder is not None and _claim(marker(folder)):
                self.said = True
                print(NOTICE, file=sys.stderr, flush=True)

        def on_end(self, _: Any) -> None:
            """Nothing to do when a compilation ends."""

    event.register("numba:compile", FirstCompile())  # type: ignore[no-untyped-call]
    _installed = True
