"""A writer thread fed by a bounded queue: slabs are serialised beside the numerics.

The pattern of :mod:`voxel.tiff_writer`, for writers that consume one item at a time:
the caller :meth:`~SlabThread.put` s items (at most `queue_slabs` wait in memory), the
thread runs ``consume(item)`` on each in order. An error in the thread is kept and
raised (as ``RuntimeError`` from it) by the next :meth:`~SlabThread.put` or by
:meth:`~SlabThread.finish`; after an error the remaining items are dropped unread.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from types import TracebackType
from typing import Generic, TypeVar

Item = TypeVar("Item")

_STOP = object()


class SlabThread(Generic[Item]):
    """Run ``consume(item)`` for each queued item in one background thread.

    Parameters
    ----------
    name : str
        Thread name, and the subject of error messages (e.g. the file written).
    consume : callable
        Called in the thread with each item, in the order they were put.
    queue_slabs : int
        Items that may wait for the thread.
    """

    def __init__(self, name: str, consume: Callable[[Item], None], *, queue_slabs: int = 2):
        if queue_slabs < 1:
            raise ValueError(f"queue_slabs must be >= 1, got {queue_slabs}")
        self.name = name
        self._consume = consume
        self._queue: queue.Queue[object] = queue.Queue(maxsize=queue_slabs)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, item: Item) -> None:
        """Queue `item` (blocks while the queue is full); raise if the thread failed."""
        self.raise_if_failed()
        self._send(item)

    def finish(self) -> None:
        """Wait until every queued item is consumed; raise if one failed."""
        self._send(_STOP)
        self._thread.join()
        self.raise_if_failed()

    def abort(self) -> None:
        """Stop the thread as soon as it finishes its current item (queued ones are dropped)."""
        if self._error is None:
            self._error = RuntimeError("aborted")
        while self._thread.is_alive():
            try:
                self._queue.put(_STOP, timeout=0.1)
            except queue.Full:
                continue
            self._thread.join(timeout=0.1)

    def raise_if_failed(self) -> None:
        """Raise ``RuntimeError`` from the thread's error, if there was one."""
        if self._error is not None:
            raise RuntimeError(f"writing {self.name} failed: {self._error}") from self._error

    def _send(self, item: object) -> None:
        while True:
            try:
                self._queue.put(item, timeout=0.5)
                return
            except queue.Full:
                if not self._thread.is_alive():
                    self.raise_if_failed()
                    return

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            if self._error is not None:
                continue  # failed or aborted: drain without work
            try:
                self._consume(item)  # type: ignore[arg-type]
            except BaseException as error:  # reported to the caller by put()/finish()
                self._error = error


class ClosingWriter:
    """A streaming writer as a context manager: ``close()`` on success, ``abort()`` on error.

    Subclasses define ``close`` (finish the file) and ``abort`` (stop and remove it).
    """

    def close(self) -> object:
        """Finish the output (subclasses)."""
        raise NotImplementedError

    def abort(self) -> None:
        """Stop without finishing; leave no output (subclasses)."""
        raise NotImplementedError

    def __enter__(self: W) -> W:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


W = TypeVar("W", bound=ClosingWriter)
