"""The progress bars of a build: shown where a person is watching, or as asked.

A build's bars (the voxels' slabs, the shell meshes) are :mod:`tqdm.auto`'s: a widget in
a Jupyter notebook, text on stderr elsewhere. ``progress=None`` (the default of
:func:`shellvox.build` and of ``shellvox build``) shows them where a person is watching:
when stderr is a terminal, or in a Jupyter kernel (the test :mod:`tqdm.autonotebook`
makes); ``True`` always, ``False`` never. A terminal that reports no size (a pseudo-terminal
nobody sized: ``script`` without a terminal, some containers' ``-t``) gets bars 80 columns
wide, where tqdm would draw nothing.
"""

from __future__ import annotations

import os
import sys
from typing import Any

from tqdm.auto import tqdm


def watched() -> bool:
    """Return whether a person is watching: stderr is a terminal, or this is a Jupyter kernel."""
    if "ipykernel.zmqshell" in sys.modules:
        return True
    isatty = getattr(sys.stderr, "isatty", None)
    try:
        return bool(isatty is not None and isatty())
    except ValueError:  # a closed stream
        return False


#: The size of bars on a terminal that reports none (columns, rows).
UNSIZED_TERMINAL = (80, 24)


def _unsized_terminal() -> bool:
    """Return whether stderr is a terminal that reports 0 columns (tqdm would draw nothing)."""
    try:
        return os.get_terminal_size(sys.stderr.fileno()).columns == 0
    except (AttributeError, OSError, ValueError):  # no file descriptor, no terminal, closed
        return False


def progress_bar(progress: bool | None, **options: Any) -> tqdm:
    """Return a :mod:`tqdm.auto` bar, shown when `progress` says so (None: :func:`watched`).

    Parameters
    ----------
    progress : bool or None
        True: shown; False: not; None: shown where a person is watching.
    **options
        tqdm's options (``total``, ``desc``, ``unit``, ``bar_format``, ...).
    """
    shown = watched() if progress is None else progress
    if shown and "ncols" not in options and _unsized_terminal():
        options = {"ncols": UNSIZED_TERMINAL[0], "nrows": UNSIZED_TERMINAL[1], **options}
    return tqdm(disable=not shown, **options)
