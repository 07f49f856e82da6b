"""Child processes that never outlive the run: they die with their parent, ignore Ctrl-C.

A terminal's Ctrl-C reaches every process of the foreground group; the children ignore
it and leave the parent to stop them (no tracebacks from workers). ``PR_SET_PDEATHSIG``
(Linux) sends them SIGKILL when the parent dies for any reason, SIGKILL included, so no
worker is ever left orphaned.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import multiprocessing
import os
import signal
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from types import TracebackType
from typing import Any, Generic, TypeVar

T = TypeVar("T")

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


def kill_pool(pool: ProcessPoolExecutor) -> None:
    """Kill a pool's worker processes now and reap them (no waiting for their tasks)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.kill()
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AssertionError, AttributeError):
            process.join(timeout=5)


class BackgroundCall(Generic[T]):
    """Run ``function(*args)`` in one spawned child process (a context manager).

    The child ignores Ctrl-C and dies with its parent; leaving the block before the
    result was taken kills it at once. (``multiprocessing.Pool`` is not used: it starts
    a new worker when one dies, and its ``terminate`` can then wait for ever.)

    Examples
    --------
    >>> with BackgroundCall(pow, 2, 10) as call:   # doctest: +SKIP
    ...     call.result()
    1024
    """

    def __init__(self, function: Callable[..., T], *args: Any) -> None:
        self._pool = ProcessPoolExecutor(
            1,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=init_child,
            initargs=(os.getpid(),),
        )
        self._future: Future[T] = self._pool.submit(function, *args)

    def result(self) -> T:
        """Wait for the child's result (or raise its exception)."""
        return self._future.result()

    def __enter__(self) -> BackgroundCall[T]:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if kind is not None or not self._future.done():
            kill_pool(self._pool)
        self._pool.shutdown(wait=True, cancel_futures=True)
