"""Run the slab tasks over the Z slabs and hand them over in z order.

:class:`SlabRunner` keeps a bounded number of slabs (:func:`shellvox.run._task.stack_slab`)
in flight on an executor and yields them in z order; the executor is a choice behind one
small interface (:class:`shellvox.run._task.SlabExecutor`), made here:

- here, in this process (:class:`InProcess`, ``workers == 1``);
- forked worker processes handing slabs back through shared memory
  (:class:`shellvox.run._fork.ForkPool`, ``workers > 1``);
- a Dask cluster (:class:`shellvox.run._cluster.DaskPool`, ``scheduler``).

With a run folder (:class:`shellvox.run._checkpoints.RunFolder`) every finished slab is also
checkpointed as a chunk file (where it is computed when that is this machine), and the
slabs a killed run finished are read back from their chunks instead of computed again.
"""

from __future__ import annotations

import collections
import contextlib
from collections.abc import Iterator
from types import TracebackType
from typing import Any

from shellvox.faults import raise_if_interrupted
from shellvox.run._checkpoints import RunFolder
from shellvox.run._task import SLAB_ARRAYS, Rows, SlabExecutor, SlabJob, SlabModel, StackSlab
from shellvox.voxel.colour import MaterialPlan
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import PageEncoder
from shellvox.voxel.io.vdb import VdbEncoder


class InProcess:
    """Slabs computed here, one at a time, when the runner asks for them.

    Parameters
    ----------
    job : SlabJob
    run : RunFolder, optional
        Checkpoint every slab there.
    """

    capacity = 1

    def __init__(self, job: SlabJob, run: RunFolder | None = None) -> None:
        self.job, self.run = job, run

    def submit(self, rows: Rows) -> Rows:
        """Nothing runs yet: the slab is computed by :meth:`result`."""
        return rows

    def result(self, handle: Rows) -> StackSlab:
        """Compute the slab (and checkpoint it)."""
        done = self.job.run(handle)
        if self.run is not None:
            self.run.save(handle, done, self.job.send)
        return done

    def close(self, failed: bool) -> None:
        """Nothing to stop."""


class SlabRunner(contextlib.AbstractContextManager["SlabRunner"]):
    """Compute the slabs of a grid and yield them in z order.

    Create it before any threads start (writers, progress bars): forked workers are
    forked here, and never again. At most ``capacity`` slabs (the workers, or a Dask
    cluster's threads plus one) are in flight while the caller holds one, so memory
    stays bounded by the slab size.

    Parameters
    ----------
    model : StackModel or TrayStack
    grid : GridSpec
    rows : int
        Rows per slab.
    workers : int
        Processes computing slabs (1: in this process); with ``scheduler="local"`` the
        local Dask cluster's worker processes.
    plan : MaterialPlan, optional
        Materials of the voxels (see :func:`stack_slab`).
    vdb : VdbEncoder, optional
        Encode each slab's VDB leaves where it is computed (see :func:`stack_slab`).
    pages : PageEncoder, optional
        Compress each slab's TIFF pages where it is computed (see :func:`stack_slab`).
    scheduler : str, optional
        A Dask scheduler's address, or ``"local"`` for a local cluster
        (:class:`shellvox.run._cluster.DaskPool`); None: this process or forked workers.
    run : RunFolder, optional
        Checkpoint every slab there, and take the slabs it already holds from it.
    """

    def __init__(
        self,
        model: SlabModel,
        grid: GridSpec,
        rows: int,
        workers: int,
        plan: MaterialPlan | None = None,
        vdb: VdbEncoder | None = None,
        *,
        pages: PageEncoder | None = None,
        send: tuple[str, ...] = SLAB_ARRAYS,
        scheduler: str | None = None,
        run: RunFolder | None = None,
    ) -> None:
        self.job = SlabJob(model, grid, plan, vdb, pages, send)
        self.run = run
        n_z = grid.shape_zyx[0]
        self.ranges = [(z, min(n_z, z + rows)) for z in range(0, n_z, rows)]
        #: Slabs read back from the run folder instead of computed.
        self.finished = run.finished(self.ranges) if run is not None else set()
        self._todo = collections.deque(r for r in self.ranges if r not in self.finished)
        self.workers = max(1, min(workers, len(self._todo)))
        self._pending: collections.deque[tuple[Rows, Any]] = collections.deque()
        self._executor = self._choose(scheduler, (min(rows, n_z), *grid.shape_zyx[1:]))
        try:
            self._fill()  # with forked workers, the first submit forks every worker
        except BaseException as error:  # e.g. a signal delivered once they are forked
            self.__exit__(type(error), error, error.__traceback__)
            raise

    def _choose(self, scheduler: str | None, slab_shape: tuple[int, int, int]) -> SlabExecutor:
        if not self._todo:
            return InProcess(self.job._replace(pages=None), self.run)
        if scheduler is not None:
            from shellvox.run._cluster import DaskPool  # dask is imported only when used

            return DaskPool(self.job, scheduler, self.workers, self.run)
        if self.workers > 1:
            from shellvox.run._fork import ForkPool

            return ForkPool(self.job, self.workers, slab_shape, self.run)
        # Here the writers' threads compress the pages beside the numerics, on the other
        # cores; worker processes compress their own, so the writing process does not
        # set the pace of many workers.
        return InProcess(self.job._replace(pages=None), self.run)

    def _fill(self) -> None:
        while self._todo and len(self._pending) < self._executor.capacity:
            rows = self._todo.popleft()
            self._pending.append((rows, self._executor.submit(rows)))

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None = None,
        traceback: TracebackType | None = None,
    ) -> None:
        self._executor.close(failed=kind is not None)

    def __iter__(self) -> Iterator[StackSlab]:
        for rows in self.ranges:
            raise_if_interrupted()  # a signal whose exception a library swallowed
            if rows in self.finished:
                yield self._load(rows)
                continue
            submitted, handle = self._pending.popleft()
            assert submitted == rows, "slabs are submitted in z order"
            done = self._executor.result(handle)
            self._fill()
            yield done

    def _load(self, rows: Rows) -> StackSlab:
        """Return a slab checkpointed by an earlier run (computed here if its chunk is bad)."""
        assert self.run is not None
        try:
            return self.run.load(rows)
        except ValueError:
            return InProcess(self.job, self.run).result(rows)
