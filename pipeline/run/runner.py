"""Run :func:`voxel.slab.compute_slab` over the Z slabs and hand them over in z order.

With a material plan, each slab's voxels also get their materials
(:func:`voxel.colour.materials.materials_for_slab`) in the same worker, when the halftone is
order-independent (blue noise); error diffusion runs in z order in the caller.

Slabs are a pure function of (model, grid, rows): :func:`stack_slab` is the one task,
wherever it runs. :class:`SlabRunner` keeps a bounded number of slabs in flight on an
executor and yields them in z order; the executor is a choice behind one small interface
(:class:`SlabExecutor`):

- here, in this process (``workers == 1``);
- forked worker processes handing slabs back through shared memory
  (:class:`pipeline.run.fork.ForkPool`, ``workers > 1``);
- a Dask cluster (:class:`pipeline.run.cluster.DaskPool`, ``scheduler``).

With a run folder (:class:`pipeline.run.checkpoints.RunFolder`) every finished slab is also
checkpointed as a chunk file (where it is computed when that is this machine), and the
slabs a killed run finished are read back from their chunks instead of computed again.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import os
from collections.abc import Iterator
from types import TracebackType
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.faults import raise_if_interrupted
from voxel.colour.materials import MaterialPlan, materials_for_slab
from voxel.geometry.layer_kernel import layer_material_counts
from voxel.grid import GridSpec
from voxel.io.tiff_pages import PageEncoder
from voxel.io.vdb.encode import VdbEncoder
from voxel.io.vdb.leaves import GridSpool
from voxel.slab import SlabResult, StackModel, compute_slab

if TYPE_CHECKING:
    from pipeline.run.checkpoints import RunFolder

#: Rows of a slab: ``(z_start, z_stop)``.
Rows = tuple[int, int]


class StackSlab(NamedTuple):
    """A computed slab and, when the halftone is order-independent, its materials.

    Attributes
    ----------
    slab : SlabResult
        Layers, colours and the signed-distance band of the rows.
    materials : (Zs, Y, X) uint8 or None
        Material index per voxel (0 void); None without a plan or with error diffusion
        (the caller runs it in z order).
    tally : (L, 256) int64 or None
        Voxels per layer (rows, ``L = K + 2``) and material (columns), with `materials`.
    vdb : list of GridSpool or None
        The slab's VDB leaves and tiles, when the runner was given an encoder.
    pages : dict of str to list of bytes, or None
        The slab's TIFF pages compressed, by file name (:class:`voxel.io.tiff_pages.PageEncoder`),
        when the runner was given a page encoder.
    """

    slab: SlabResult
    materials: NDArray[np.uint8] | None
    tally: NDArray[np.int64] | None = None
    vdb: list[GridSpool] | None = None
    pages: dict[str, list[bytes]] | None = None


def material_tally(
    layers: NDArray[np.uint8], materials: NDArray[np.uint8], n_layers: int
) -> NDArray[np.int64]:
    """Return voxels per layer and material ``(n_layers, 256) int64`` of a slab."""
    counts: NDArray[np.int64] = layer_material_counts(layers, materials, n_layers)
    return counts


def stack_slab(
    model: StackModel,
    grid: GridSpec,
    plan: MaterialPlan | None,
    z_start: int,
    z_stop: int,
    vdb: VdbEncoder | None = None,
    pages: PageEncoder | None = None,
) -> StackSlab:
    """Return the slab of rows ``z_start..z_stop`` with its materials (a pure function).

    With `vdb`, also its VDB leaves and tiles (only when the materials, if any, are made
    here: with error diffusion they are not, and the caller encodes the slab). With
    `pages`, also its TIFF pages compressed (those of ``materials.tif`` only when the
    materials are made here).
    """
    slab = compute_slab(model, grid, z_start, z_stop)
    materials = tally = None
    if plan is not None:
        if plan.halftone != "blue-noise":
            encoded_pages = None if pages is None else pages.encode(slab.layers, slab.rgba, None)
            return StackSlab(slab, None, pages=encoded_pages)
        materials = materials_for_slab(slab.layers, slab.rgba, z_start, plan).materials
        tally = material_tally(slab.layers, materials, plan.core_layer + 1)
    encoded = None
    if vdb is not None:
        is_colour = np.zeros(256, dtype=bool)
        is_colour[list(model.colour_layers)] = True
        encoded = vdb.encode(
            z_start, slab.layers, slab.rgba[..., :3], is_colour[slab.layers], slab.sdf, materials
        )
    encoded_pages = None if pages is None else pages.encode(slab.layers, slab.rgba, materials)
    return StackSlab(slab, materials, tally, encoded, encoded_pages)


def resolve_workers(workers: int) -> int:
    """Return the number of slab processes: `workers`, or one per core when it is 0.

    Forked workers are only used where ``fork`` is available (Linux); elsewhere 1.
    """
    if "fork" not in multiprocessing.get_all_start_methods():
        return 1
    if workers > 0:
        return workers
    if hasattr(os, "sched_getaffinity"):  # the cores this process may use (Linux)
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


#: The voxel arrays of a slab (:class:`voxel.slab.SlabResult`) a chunk may leave out.
SLAB_ARRAYS = ("layers", "rgba", "sdf", "sdf_band")


class SlabJob(NamedTuple):
    """What every slab task needs, sent to (or inherited by) each worker once.

    Attributes
    ----------
    model : StackModel
    grid : GridSpec
    plan : MaterialPlan or None
        Materials of the voxels (see :func:`stack_slab`).
    vdb : VdbEncoder or None
        Encode each slab's VDB leaves where it is computed (see :func:`stack_slab`).
    pages : PageEncoder or None
        Compress each slab's TIFF pages where it is computed (see :func:`stack_slab`).
    send : tuple of str
        The slab's arrays (of :data:`SLAB_ARRAYS`) the writing process uses when a slab
        comes with its pages; the others travel as the pages and VDB leaves only
        (:func:`pipeline.run.chunks.encode_chunk`: the Dask wire and the checkpoints).
    """

    model: StackModel
    grid: GridSpec
    plan: MaterialPlan | None
    vdb: VdbEncoder | None
    pages: PageEncoder | None = None
    send: tuple[str, ...] = ("layers", "rgba", "sdf", "sdf_band")

    def run(self, rows: Rows) -> StackSlab:
        """Return the slab of `rows` (:func:`stack_slab`)."""
        return stack_slab(self.model, self.grid, self.plan, rows[0], rows[1], self.vdb, self.pages)


class SlabExecutor(Protocol):
    """Where slab tasks run: submit rows, later collect their slab (in any order).

    ``capacity`` is how many tasks the runner keeps submitted; :meth:`close` ends the
    workers (at once when ``failed``).
    """

    capacity: int

    def submit(self, rows: Rows) -> Any:
        """Start the slab of `rows`; return a handle for :meth:`result`."""

    def result(self, handle: Any) -> StackSlab:
        """Wait for a submitted slab and return it."""

    def close(self, failed: bool) -> None:
        """Stop the workers (kill them at once when `failed`)."""


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
    model : StackModel
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
        (:class:`pipeline.run.cluster.DaskPool`); None: this process or forked workers.
    run : RunFolder, optional
        Checkpoint every slab there, and take the slabs it already holds from it.
    """

    def __init__(
        self,
        model: StackModel,
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
            from pipeline.run.cluster import DaskPool  # dask is imported only when used

            return DaskPool(self.job, scheduler, self.workers, self.run)
        if self.workers > 1:
            from pipeline.run.fork import ForkPool

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
