"""Child processes that never outlive the run: they die with their parent, ignore Ctrl-C.

A terminal's Ctrl-C reaches every process of the foreground group; the children ignore
it and leave the parent to stop them (no tracebacks from workers). ``PR_SET_PDEATHSIG``
(Linux) sends them SIGKILL when the parent dies for any reason, SIGKILL included, so no
worker is ever left orphaned.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal

_PR_SET_PDEATHSIG = 1


def init_child(parent_pid: int) -> None:
    """Initialise a worker process (a ``multiprocessing`` pool initializer).

    Parameters
    ----------
    parent_pid : int
        The process that must outlive this one; if it is already gone, exit at once.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the parent still terminates its children
        pass
    if os.getppid() != parent_pid:  # the parent died before the death signal was armed
        os._exit(1)
