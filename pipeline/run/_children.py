"""Child processes that never outlive the run: they die with their parent, ignore Ctrl-C.

A terminal's Ctrl-C reaches every process of the foreground group; the children ignore
it and leave the parent to stop them (no tracebacks from workers). They start with
SIGINT and SIGTERM blocked (:class:`shellvox.faults.DeferredSignals`), so neither can hit
a child before :func:`init_child` has set its dispositions. ``PR_SET_PDEATHSIG`` (Linux)
sends them SIGKILL when the parent dies for any reason, SIGKILL included, so no worker is
ever left orphaned. :class:`ChildPool` (forked slab workers) and :class:`ChildCall` (one
function in a spawned process) kill them at once when the run fails, and fail instead of
hanging when one of them dies.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import multiprocessing
import os
import pickle
import signal
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from multiprocessing import resource_tracker
from multiprocessing.connection import Connection
from multiprocessing.reduction import ForkingPickler
from typing import Any, Generic, TypeVar

from shellvox.faults import DeferredSignals

_PR_SET_PDEATHSIG = 1
_STOP = {signal.SIGINT, signal.SIGTERM}

T = TypeVar("T")


def init_child(parent_pid: int) -> None:
    """Initialise a worker process (a ``multiprocessing`` pool initializer).

    Parameters
    ----------
    parent_pid : int
        The process that must outlive this one; if it is already gone, exit at once.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the parent still terminates its children
        pass
    if os.getppid() != parent_pid:  # the parent died before the death signal was armed
        os._exit(1)


class ChildPool(contextlib.AbstractContextManager["ChildPool"]):
    """Forked worker processes (a ``ProcessPoolExecutor``) that never outlive the run.

    The workers are forked at the first :meth:`submit`, from the calling thread (start
    them before any other thread), with SIGINT and SIGTERM blocked until
    :func:`init_child`. A worker that dies (e.g. killed for lack of memory) fails the
    pending futures with ``BrokenProcessPool``. Leaving the block with an exception kills
    the workers at once instead of waiting for their tasks (:meth:`kill`, which also
    unblocks the executor when a worker died half-way through sending a result). Tasks
    should be small (the workers inherit the data): a task being written to a worker
    that is then killed could block the executor's shutdown.

    Parameters
    ----------
    workers : int
        Processes.
    """

    def __init__(self, workers: int) -> None:
        self._executor = ProcessPoolExecutor(
            workers,
            mp_context=multiprocessing.get_context("fork"),
            initializer=init_child,
            initargs=(os.getpid(),),
        )

    def submit(self, function: Callable[..., T], /, *args: Any) -> Future[T]:
        """Run ``function(*args)`` in a worker (forking the workers on the first call)."""
        with DeferredSignals():
            return self._executor.submit(function, *args)

    def kill(self) -> None:
        """Kill every worker now and wait (up to 5 s each) until they are gone."""
        processes = list((getattr(self._executor, "_processes", None) or {}).values())
        for process in processes:
            with contextlib.suppress(OSError, ValueError):
                process.kill()
        for process in processes:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                process.join(timeout=5)
        # A worker killed while it wrote its result leaves the executor's reader waiting
        # for the rest of that message for ever, and shutdown with it. With every worker
        # gone, this process holds the last writing end: closing it ends the wait (EOF:
        # the pool is broken) and shutdown returns.
        writer = getattr(getattr(self._executor, "_result_queue", None), "_writer", None)
        if writer is not None:
            with contextlib.suppress(OSError):
                writer.close()

    def __exit__(self, kind: type[BaseException] | None, *_: object) -> None:
        if kind is not None:  # do not wait for results nobody will use
            self.kill()
        self._executor.shutdown(wait=True, cancel_futures=True)


class ChildDied(RuntimeError):
    """A child process ended without returning its result (e.g. killed for lack of memory)."""


class ChildCall(contextlib.AbstractContextManager["ChildCall[T]"], Generic[T]):
    """``function(*args)`` computed in a spawned process that never outlives the run.

    Unlike a task of a ``multiprocessing.Pool`` (which waits for ever when its worker
    dies), :meth:`result` raises :class:`ChildDied` when the process ends without a
    result. Leaving the block kills the process if it is still running. The process
    starts with SIGINT and SIGTERM blocked until :func:`init_child`.

    Parameters
    ----------
    function : callable
        A module-level function (pickled by reference).
    *args
        Its arguments (pickled).
    """

    def __init__(self, function: Callable[..., T], /, *args: Any) -> None:
        context = multiprocessing.get_context("spawn")
        task_receive, task_send = context.Pipe(duplex=False)
        self._receive, result_send = context.Pipe(duplex=False)
        # The task goes through a pipe of its own, not the process's arguments: those are
        # written while this process still holds the reading end, so a child killed before
        # it has read them all would block the write for ever; and importing the
        # function's module (seconds) comes after init_child has bound the child to us.
        self._process = context.Process(
            target=_call, args=(task_receive, result_send, os.getpid()), daemon=True
        )
        with DeferredSignals():
            # Spawning needs multiprocessing's resource tracker, which unblocks SIGINT and
            # SIGTERM once it has started it: start it first, then block them again.
            resource_tracker.ensure_running()
            signal.pthread_sigmask(signal.SIG_BLOCK, _STOP)
            self._process.start()
        task_receive.close()  # the child's ends: EOF / EPIPE here once the child is gone
        result_send.close()
        try:
            # multiprocessing's own pickler: protocol 5 would unpickle read-only arrays
            task_send.send_bytes(ForkingPickler.dumps((function, args)))
        except OSError:  # the child is already gone: result() says so
            pass
        finally:
            task_send.close()

    def result(self) -> T:
        """Wait for the result; re-raise the function's exception.

        Raises
        ------
        ChildDied
            The process ended without a result.
        """
        try:
            ok, value = self._receive.recv()
        except (EOFError, OSError):
            self._process.join(timeout=5)
            raise ChildDied(
                f"the process ended without a result (exit status {self._process.exitcode}; "
                "often: killed for lack of memory)"
            ) from None
        if not ok:
            raise value
        result: T = value
        return result

    def __exit__(self, kind: type[BaseException] | None, *_: object) -> None:
        if self._process.is_alive():
            self._process.kill()
        self._process.join(timeout=5)
        self._receive.close()


def _call(task: Connection, send: Connection, parent_pid: int) -> None:
    init_child(parent_pid)
    try:
        function, args = pickle.loads(task.recv_bytes())
        reply: tuple[bool, Any] = (True, function(*args))
    except Exception as error:  # the parent re-raises it
        reply = (False, error)
    try:
        send.send(reply)
    except Exception as error:  # e.g. an exception that does not pickle
        send.send((False, RuntimeError(f"{type(error).__name__}: {error}")))
