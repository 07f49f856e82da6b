"""Exit statuses, the one-line message of every failure, and signals turned into exceptions.

The CLI's error boundary (:func:`pipeline.cli.main`) maps every exception to one line on
stderr and one of these exit statuses:

==========  ==========================================================================
status      meaning
==========  ==========================================================================
0           success
1           internal error (a bug in shellvox: rerun with ``--debug`` and report it)
2           bad input: a file, an option or a folder the user gave (the line says which)
3           out of disk space, or the output folder cannot be written
4           out of memory (a ``MemoryError``, or a slab worker killed, e.g. by the OOM killer)
130         interrupted by SIGINT (Ctrl-C)
143         terminated by SIGTERM
==========  ==========================================================================

SIGINT and SIGTERM raise :class:`Interrupted` in the main thread, so every ``with`` block
on the way out removes its temporary files and stops its workers.
"""

from __future__ import annotations

import contextlib
import errno
import signal
from collections.abc import Iterator
from types import FrameType

from pipeline.errors import InputError, SlabWorkerDied

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_INPUT = 2
EXIT_DISK = 3
EXIT_MEMORY = 4
EXIT_SIGINT = 128 + signal.SIGINT
EXIT_SIGTERM = 128 + signal.SIGTERM

_DISK_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG}


class Interrupted(BaseException):
    """The run was stopped by a signal (SIGINT or SIGTERM)."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    # Further signals are ignored until the block ends: cleanup must not be cut short.
    for other in (signal.SIGINT, signal.SIGTERM):
        signal.signal(other, signal.SIG_IGN)
    raise Interrupted(signum)


@contextlib.contextmanager
def signals_raise() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted` in the main thread.

    After the first signal, further ones are ignored until the block ends, so the
    cleanup on the way out (temporary files, workers) finishes.
    """
    previous = {
        signum: signal.signal(signum, _raise_interrupted)
        for signum in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def describe(error: BaseException) -> tuple[int, str]:
    """Return the exit status and the one-line message for an exception.

    Examples
    --------
    >>> describe(InputError("a.obj", "not found", "check the path"))
    (2, 'a.obj: not found; check the path')
    >>> describe(OSError(28, "No space left on device", "out/layers.tif"))[0]
    3
    """
    if isinstance(error, InputError):
        return EXIT_INPUT, str(error)
    if isinstance(error, Interrupted):
        status = EXIT_SIGINT if error.signum == signal.SIGINT else EXIT_SIGTERM
        return status, f"interrupted ({error}); no partial output was kept"
    if isinstance(error, KeyboardInterrupt):
        return EXIT_SIGINT, "interrupted (SIGINT); no partial output was kept"
    if isinstance(error, SlabWorkerDied):
        return EXIT_MEMORY, f"{error}; no partial output was kept"
    if isinstance(error, MemoryError):
        return EXIT_MEMORY, (
            "out of memory; no partial output was kept; rerun with a smaller --slab-mb, "
            "fewer --workers or a larger --voxel-size"
        )
    os_error = _os_error(error)
    if os_error is not None and os_error.errno in _DISK_ERRNOS:
        where = os_error.filename or "the output folder"
        reason = os_error.strerror or str(os_error)
        fix = (
            "free some space or choose another -o DIR"
            if os_error.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
            else "choose a folder you can write to with -o DIR"
        )
        return EXIT_DISK, f"{where}: cannot write ({reason}); no partial output was kept; {fix}"
    summary = f"{type(error).__name__}: {error}".replace("\n", " ")
    return EXIT_INTERNAL, (
        f"internal error ({summary}); no partial output was kept; rerun with --debug for "
        "the traceback and report it"
    )


def _os_error(error: BaseException) -> OSError | None:
    """Return the OSError behind `error` (itself, or a cause raised from a writer thread)."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, OSError):
            return current
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return None
