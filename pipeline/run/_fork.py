"""Forked slab workers that hand their slabs back through shared memory.

The workers inherit the slab job (the model, with its AABB tree and texture, is not
pickled): they are forked once, at the first :meth:`ForkPool.submit`, before the caller
starts any thread. Each slab comes back through a shared-memory slot
(:mod:`shellvox.run._slots`); with a run folder the worker also writes the slab's chunk
itself, so checkpointing costs the parent nothing. A worker that dies (e.g. killed for
lack of memory) fails the build with a clear error instead of hanging it. Workers ignore
Ctrl-C and die with the parent (:class:`shellvox.run._children.ChildPool`); closing the pool
after a failure kills them at once instead of waiting for the slabs they are computing.
"""

from __future__ import annotations

from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING

from shellvox.errors import SlabWorkerDied, opt
from shellvox.run._children import ChildPool
from shellvox.run._slots import EXTRA_SLOTS, SlabInSlot, SlabSlots
from shellvox.run._task import Rows, SlabJob, StackSlab

if TYPE_CHECKING:
    from shellvox.run._checkpoints import RunFolder

#: Inherited by the forked workers: the job, the slots and the run folder.
_WORKER: tuple[SlabJob, SlabSlots, RunFolder | None] | None = None

_DIED = (
    "a slab worker process died (often: out of memory); rerun with a smaller "
    f"{opt('slab_mb')} or fewer {opt('workers')}"
)


class ForkPool:
    """``workers`` forked processes computing slabs (a :class:`SlabExecutor`).

    Parameters
    ----------
    job : SlabJob
    workers : int
    slab_shape : (3,) int
        Largest slab ``(Zs, Y, X)`` (sizes the shared slots).
    run : RunFolder, optional
        The workers checkpoint every slab there.
    """

    def __init__(
        self, job: SlabJob, workers: int, slab_shape: tuple[int, int, int], run: RunFolder | None
    ) -> None:
        global _WORKER
        self.capacity = workers
        # workers, plus slabs the writers may still hold (a queue of 2 per thread)
        self._slots = SlabSlots(workers + EXTRA_SLOTS, slab_shape)
        _WORKER = (job, self._slots, run)
        self._pool = ChildPool(workers)

    def submit(self, rows: Rows) -> Future[SlabInSlot]:
        """Send the slab to a worker (a slot must come free first)."""
        slot = self._slots.take()
        try:
            return self._pool.submit(_worker_slab, *rows, slot)
        except BrokenProcessPool:
            raise SlabWorkerDied(_DIED) from None

    def result(self, handle: Future[SlabInSlot]) -> StackSlab:
        """Wait for the slab; its arrays are views of its slot."""
        try:
            item = handle.result()
        except BrokenProcessPool:
            raise SlabWorkerDied(_DIED) from None
        slab, materials = self._slots.load(item)
        return StackSlab(slab, materials, item.tally, item.vdb, item.pages)

    def close(self, failed: bool) -> None:
        """Stop the workers (kill them at once when `failed`)."""
        global _WORKER
        self._pool.__exit__(BaseException if failed else None, None, None)
        _WORKER = None


def _worker_slab(z_start: int, z_stop: int, slot: int) -> SlabInSlot:
    assert _WORKER is not None, "slab workers must be forked by ForkPool"
    job, slots, run = _WORKER
    done = job.run((z_start, z_stop))
    if run is not None:
        run.save((z_start, z_stop), done, job.send)
    return slots.store(slot, done.slab, done.materials, done.tally, done.vdb, done.pages, job.send)
