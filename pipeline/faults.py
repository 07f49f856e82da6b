"""Exit statuses, the one-line message of every failure, and signals turned into exceptions.

The CLI's error boundary (:func:`shellvox.cli.main`) maps every exception to one line on
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
on the way out removes its temporary files and stops its workers; a signal that arrives
during that cleanup is recorded, not raised.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import sys
from collections.abc import Callable, Iterator
from types import FrameType

from shellvox.errors import InputError, SlabWorkerDied, notes

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


_STOP = {signal.SIGINT, signal.SIGTERM}

#: The signals received in the current :func:`signals_raise` block, first first.
_received: list[int] = []

#: Open :class:`DeferredSignals` blocks.
_deferring = [0]


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    _received.append(signum)
    # Within a DeferredSignals block, or while an exception is being handled (cleanup:
    # ``__exit__``, ``finally``, ``except`` on the way out), the signal is only recorded:
    # it is raised when the block closes, or by the next raise_if_interrupted().
    if not _deferring[0] and sys.exception() is None:
        raise Interrupted(signum)


@contextlib.contextmanager
def signals_raise() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted` in the main thread.

    A signal that arrives while an exception is being handled (the cleanup on the way
    out of an earlier signal or error) is recorded, not raised, so the cleanup finishes.
    Libraries that catch ``BaseException`` (trimesh does, around optional imports) may
    swallow an :class:`Interrupted`; long-running loops call :func:`raise_if_interrupted`
    so a recorded signal still stops the run. One that lands inside a finaliser (where
    Python can only print an exception) is recorded the same way, and not printed.
    """
    _received.clear()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    previous = {
        signum: signal.signal(signum, _raise_interrupted)
        for signum in (signal.SIGINT, signal.SIGTERM)
    }
    hook = sys.unraisablehook
    sys.unraisablehook = _unraisable_without_signals(hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        # The signals blocked before stay blocked: ``python -m shellvox.cli`` blocks them
        # from its first line, so no signal cuts the interpreter's shutdown either.
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _received.clear()  # not to stop a later run in this process


def _unraisable_without_signals(
    hook: Callable[[sys.UnraisableHookArgs], object],
) -> Callable[[sys.UnraisableHookArgs], None]:
    """Return `hook` without the :class:`Interrupted` raised inside a finaliser.

    A signal that lands while a finaliser runs (a library's ``__del__``, during garbage
    collection) raises there, where Python can only print it; it is recorded all the same,
    and the next :func:`raise_if_interrupted` stops the run.
    """

    def unraisable(unraisable: sys.UnraisableHookArgs) -> None:
        if not isinstance(unraisable.exc_value, Interrupted):
            hook(unraisable)

    return unraisable


def unblock_signals() -> None:
    """Unblock SIGINT and SIGTERM in this thread (a pending one is delivered now)."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)


class DeferredSignals(contextlib.AbstractContextManager["DeferredSignals"]):
    """Hold SIGINT and SIGTERM back until :meth:`close` (or the block's end).

    For code that must not be cut: imports (whose modules would be left half made), and
    setting up what the cleanup needs (temporary files, threads, workers) together with
    registering that cleanup. A signal that arrives meanwhile raises :class:`Interrupted`
    at :meth:`close` (unless an exception is already on its way out).

    The signals are also blocked in this thread: child processes and threads started
    meanwhile inherit the mask, so a terminal's Ctrl-C (sent to the whole process group)
    cannot hit a child before it has set up its own handling
    (:func:`shellvox.run._children.init_child`). The mask alone would not hold them back from
    this process: any other thread that does not block them receives them, and Python
    runs the handler in the main thread all the same.
    """

    def __init__(self) -> None:
        self._previous: set[int | signal.Signals] | None = None

    def __enter__(self) -> DeferredSignals:
        _deferring[0] += 1
        self._previous = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP)
        return self

    def close(self) -> None:
        """End the block; raise :class:`Interrupted` if a signal arrived (see above)."""
        if self._previous is None:
            return
        previous, self._previous = self._previous, None
        _deferring[0] -= 1
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)  # delivers a blocked one
        if not _deferring[0] and sys.exception() is None:
            raise_if_interrupted()

    def __exit__(self, *exc: object) -> None:
        self.close()


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal arrived in this :func:`signals_raise` block.

    Called by long-running loops: a signal whose exception was swallowed (or recorded
    during some unrelated exception handling) still stops the run.
    """
    if _received:
        raise Interrupted(_received[0])


def describe(error: BaseException) -> tuple[int, str]:
    """Return the exit status and the one-line message of the command line for an exception.

    The options the message names are worded as the command line's flags
    (:meth:`shellvox.errors.InputError.words`). Notes added to the exception
    (``add_note``, e.g. that finished slabs are kept for ``--resume``) end the line.

    Examples
    --------
    >>> describe(InputError("a.obj", "not found", "check the path"))
    (2, 'a.obj: not found; check the path')
    >>> describe(OSError(28, "No space left on device", "out/layers.tif"))[0]
    3
    """
    status, line = _describe(error)
    return status, "; ".join([line, *notes(error, "cli")])


def _describe(error: BaseException) -> tuple[int, str]:
    """Return :func:`describe`'s status and line, without the exception's notes."""
    if isinstance(error, InputError):
        return EXIT_INPUT, error.words("cli")
    error = interruption(error) or error
    if isinstance(error, Interrupted):
        status = EXIT_SIGINT if error.signum == signal.SIGINT else EXIT_SIGTERM
        return status, f"interrupted ({error}); no partial output was kept"
    if isinstance(error, KeyboardInterrupt):
        return EXIT_SIGINT, "interrupted (SIGINT); no partial output was kept"
    if isinstance(error, SlabWorkerDied):
        return EXIT_MEMORY, f"{error.words('cli')}; no partial output was kept"
    if isinstance(error, MemoryError):
        return EXIT_MEMORY, (
            "out of memory; no partial output was kept; rerun with a smaller --slab-mb, "
            "fewer --workers or a larger --voxel-size"
        )
    cause = os_error(error)
    if cause is not None and cause.errno in _DISK_ERRNOS:
        where = cause.filename or "the output folder"
        reason = cause.strerror or os.strerror(cause.errno)
        fix = (
            "free some space or choose another -o DIR"
            if cause.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
            else "choose a folder you can write to with -o DIR"
        )
        return EXIT_DISK, f"{where}: cannot write ({reason}); no partial output was kept; {fix}"
    summary = f"{type(error).__name__}: {error}".replace("\n", " ")
    return EXIT_INTERNAL, (
        f"internal error ({summary}); no partial output was kept; rerun with --debug for "
        "the traceback and report it"
    )


def interruption(error: BaseException) -> BaseException | None:
    """Return the signal behind `error`: itself, or one whose unwinding raised it.

    A library's cleanup can fail while a signal unwinds the stack (a zip archive refuses to
    close while the interrupted member is open); the run was stopped all the same.

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise Interrupted(2)
    ...     finally:
    ...         raise ValueError("cannot close the archive")
    ... except ValueError as error:
    ...     interruption(error)
    Interrupted('SIGINT')
    """
    return _behind(error, (Interrupted, KeyboardInterrupt))


def os_error(error: BaseException) -> OSError | None:
    """Return the OSError behind `error` (itself, or a cause raised from a writer thread)."""
    cause = _behind(error, (OSError,))
    return cause if isinstance(cause, OSError) else None


def _behind(error: BaseException, kinds: tuple[type[BaseException], ...]) -> BaseException | None:
    """Return the first of `error` and its causes and contexts that is one of `kinds`."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, kinds):
            return current
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return None
