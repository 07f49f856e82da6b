"""A writer thread fed by a bounded queue: slabs are serialised beside the numerics.

The caller :meth:`~SlabThread.put` s items (at most `queue_slabs` wait in memory); the
thread runs ``consume(item)`` on each in order, or hands them to one call of
``run(items)`` as an iterator (:meth:`SlabThread.streaming`, for tifffile, which pulls its
pages). An error in the thread is kept and raised (as ``RuntimeError`` from it) by the
next :meth:`~SlabThread.put` or by :meth:`~SlabThread.finish`; after an error the
remaining items are dropped unread. :class:`SliceWriter` is the common part of the
printer-slice writers: PNG slices encoded in parallel (zlib releases the GIL).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Generic, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.io._compression import check_level

FirstRow = Literal["max_y", "min_y"]

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
        self._start(name, lambda items: _each(consume, items), queue_slabs)

    @classmethod
    def streaming(
        cls, name: str, run: Callable[[Iterator[Item]], None], *, queue_slabs: int = 2
    ) -> SlabThread[Item]:
        """Return a thread that runs ``run(items)`` once, over the items as they are put."""
        thread = cls.__new__(cls)
        thread._start(name, run, queue_slabs)
        return thread

    def _start(self, name: str, run: Callable[[Iterator[Item]], None], queue_slabs: int) -> None:
        if queue_slabs < 1:
            raise ValueError(f"queue_slabs must be >= 1, got {queue_slabs}")
        self.name = name
        self._run_items = run
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
        self.stop()
        self.raise_if_failed()

    def stop(self) -> None:
        """Wait until every queued item is consumed (see :meth:`raise_if_failed`)."""
        self._send(_STOP)
        self._thread.join()

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

    def _items(self) -> Iterator[Item]:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            if self._error is None:  # failed or aborted: drain without work
                yield item  # type: ignore[misc]

    def _run(self) -> None:
        items = self._items()
        try:
            self._run_items(items)
        except BaseException as error:  # reported to the caller by put()/finish()
            self._error = error
        for _ in items:  # drain up to the stop
            pass


def _each(consume: Callable[[Item], None], items: Iterable[Item]) -> None:
    for item in items:
        consume(item)


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

    def __exit__(self, kind: type[BaseException] | None, *_: object) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


W = TypeVar("W", bound=ClosingWriter)


class SliceWriter(ClosingWriter):
    """Common part of the printer-slice writers: PNG slices of each slab, in parallel.

    A subclass calls :meth:`_start_slices` once its checks are done, puts ``(z0, slab)``
    items into ``self._thread`` and defines :meth:`_encode` (one ``(Y, X[, 4])`` plane to
    PNG bytes, rows in the chosen order) and :meth:`_store` (where slice ``z`` goes).

    Parameters
    ----------
    first_row : {"max_y", "min_y"}
        Which end of the y axis is image row 0.
    threads : int
        Slices encoded in parallel.
    level : int, optional
        Of the PNG data: None, the fast setting (:mod:`shellvox.voxel.io._compression`), or zlib's
        0..9.
    """

    def __init__(self, first_row: FirstRow, threads: int, level: int | None) -> None:
        if first_row not in ("max_y", "min_y"):
            raise ValueError(f"first_row must be 'max_y' or 'min_y', got {first_row!r}")
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        check_level(level)
        self.first_row: FirstRow = first_row
        self._threads = threads
        self._level = level

    def _start_slices(self, name: str, queue_slabs: int) -> None:
        """Start the encoding pool and the writer thread (after every check)."""
        self._pool = (
            ThreadPoolExecutor(self._threads, thread_name_prefix=f"png:{name}")
            if self._threads > 1
            else None
        )
        self._thread: SlabThread[tuple[int, NDArray[np.uint8] | list[bytes]]] = SlabThread(
            name, self._write_slices, queue_slabs=queue_slabs
        )

    def _rows(self, plane: NDArray[Any]) -> NDArray[Any]:
        """Return `plane` with its rows in the file's order (:attr:`first_row`)."""
        return plane[::-1] if self.first_row == "max_y" else plane

    def _encode(self, plane: NDArray[np.uint8]) -> bytes:
        raise NotImplementedError

    def _store(self, z: int, data: bytes) -> None:
        raise NotImplementedError

    def _write_slices(self, item: tuple[int, NDArray[np.uint8] | list[bytes]]) -> None:
        """In the writer thread: encode a slab's slices (in parallel) and store them in order.

        A list of bytes holds slices encoded already (where the slab was computed).
        """
        z0, slab = item
        if isinstance(slab, list):
            pngs: Iterable[bytes] = slab
        elif self._pool is not None:
            pngs = self._pool.map(self._encode, slab)
        else:
            pngs = map(self._encode, slab)
        for z, data in enumerate(pngs, start=z0):
            self._store(z, data)

    def _stop_slices(self) -> None:
        """Stop the writer thread and the pool without finishing."""
        self._thread.abort()
        self._shutdown_pool()

    def _shutdown_pool(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
