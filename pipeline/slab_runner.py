"""Run :func:`voxel.slab.compute_slab` over the Z slabs, in order, here or in worker processes.

With a material plan, each slab's voxels also get their materials
(:func:`voxel.materials.materials_for_slab`) in the same worker, when the halftone is
order-independent (blue noise); error diffusion runs in z order in the caller.

Slabs are a pure function of (model, grid, rows), so they can be computed anywhere; the
caller writes them in z order as they come back. With ``workers > 1`` the slabs run in
forked processes (the model, with its AABB tree and texture, is inherited, not pickled),
forked once, before the caller starts any thread. ``workers`` slabs are computed while
the caller holds one, so memory stays bounded by the slab size times ``workers + 1``. A
worker that dies (e.g. killed for lack of memory) fails the build with a clear error
instead of hanging it. Workers ignore Ctrl-C and die with the parent
(:class:`pipeline.children.ChildPool`); leaving the runner early (an error, an interrupt)
kills them at once instead of waiting for the slabs they are computing.
"""

from __future__ import annotations

import collections
import contextlib
import multiprocessing
import os
from collections.abc import Iterator
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pipeline.children import ChildPool
from pipeline.errors import SlabWorkerDied
from pipeline.estimate import EXTRA_SLOTS
from pipeline.faults import raise_if_interrupted
from pipeline.slab_slots import SlabInSlot, SlabSlots
from voxel.grid import GridSpec
from voxel.layer_kernel import layer_material_counts
from voxel.materials import MaterialPlan, materials_for_slab
from voxel.slab import SlabResult, StackModel, compute_slab
from voxel.vdb_encode import VdbEncoder
from voxel.vdb_leaves import GridSpool

_WORKER: tuple[StackModel, GridSpec, MaterialPlan | None, VdbEncoder | None, SlabSlots] | None = (
    None
)


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
    """

    slab: SlabResult
    materials: NDArray[np.uint8] | None
    tally: NDArray[np.int64] | None = None
    vdb: list[GridSpool] | None = None


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
) -> StackSlab:
    """Return the slab of rows ``z_start..z_stop`` with its materials (a pure function).

    With `vdb`, also its VDB leaves and tiles (only when the materials, if any, are made
    here: with error diffusion they are not, and the caller encodes the slab).
    """
    slab = compute_slab(model, grid, z_start, z_stop)
    materials = tally = None
    if plan is not None:
        if plan.halftone != "blue-noise":
            return StackSlab(slab, None)
        materials = materials_for_slab(slab.layers, slab.rgba, z_start, plan).materials
        tally = material_tally(slab.layers, materials, plan.core_layer + 1)
    encoded = None
    if vdb is not None:
        is_colour = np.zeros(256, dtype=bool)
        is_colour[list(model.colour_layers)] = True
        encoded = vdb.encode(
            z_start, slab.layers, slab.rgba[..., :3], is_colour[slab.layers], slab.sdf, materials
        )
    return StackSlab(slab, materials, tally, encoded)


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


class SlabRunner(contextlib.AbstractContextManager["SlabRunner"]):
    """Compute the slabs of a grid, in z order.

    Create it before any threads start (writers, progress bars): the workers are forked
    here, and never again.

    Parameters
    ----------
    model : StackModel
    grid : GridSpec
    rows : int
        Rows per slab.
    workers : int
        Processes computing slabs (1: in this process).
    plan : MaterialPlan, optional
        Materials of the voxels (see :func:`stack_slab`).
    vdb : VdbEncoder, optional
        Encode each slab's VDB leaves where it is computed (see :func:`stack_slab`).
    """

    def __init__(
        self,
        model: StackModel,
        grid: GridSpec,
        rows: int,
        workers: int,
        plan: MaterialPlan | None = None,
        vdb: VdbEncoder | None = None,
    ) -> None:
        self.model, self.grid, self.rows, self.plan, self.vdb = model, grid, rows, plan, vdb
        n_z = grid.shape_zyx[0]
        self._ranges = iter([(z, min(n_z, z + rows)) for z in range(0, n_z, rows)])
        self.workers = max(1, min(workers, -(-n_z // rows)))
        self._pool: ChildPool | None = None
        self._pending: collections.deque[Future[SlabInSlot]] = collections.deque()
        if self.workers > 1:
            global _WORKER
            # workers, plus slabs the writers may still hold (a queue of 2 per thread)
            self._slots = SlabSlots(
                self.workers + EXTRA_SLOTS, (min(rows, n_z), *grid.shape_zyx[1:])
            )
            _WORKER = (model, grid, plan, vdb, self._slots)  # inherited by the forked workers
            self._pool = ChildPool(self.workers)
            try:
                for _ in range(self.workers):  # the first submit forks every worker
                    self._submit()
            except BaseException as error:  # e.g. a signal delivered once they are forked
                self.__exit__(type(error), error, error.__traceback__)
                raise

    def _submit(self) -> None:
        job = next(self._ranges, None)
        if job is not None and self._pool is not None:
            slot = self._slots.take()
            self._pending.append(self._pool.submit(_worker_slab, *job, slot))

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        global _WORKER
        if self._pool is not None:
            self._pool.__exit__(kind, *exc)  # kills the workers on an error
            _WORKER = None

    def __iter__(self) -> Iterator[StackSlab]:
        if self._pool is None:
            for z_start, z_stop in self._ranges:
                raise_if_interrupted()
                yield stack_slab(self.model, self.grid, self.plan, z_start, z_stop, self.vdb)
            return
        while self._pending:
            raise_if_interrupted()  # a signal whose exception a library swallowed
            try:
                item = self._pending.popleft().result()
                slab, materials = self._slots.load(item)
                result = StackSlab(slab, materials, item.tally, item.vdb)
                self._submit()
            except BrokenProcessPool:  # from result() or from submit()
                raise SlabWorkerDied(
                    "a slab worker process died (often: out of memory); rerun with a "
                    "smaller --slab-mb or fewer --workers"
                ) from None
            yield result


def _worker_slab(z_start: int, z_stop: int, slot: int) -> SlabInSlot:
    assert _WORKER is not None, "slab workers must be forked by SlabRunner"
    model, grid, plan, vdb, slots = _WORKER
    done = stack_slab(model, grid, plan, z_start, z_stop, vdb)
    return slots.store(slot, done.slab, done.materials, done.tally, done.vdb)
