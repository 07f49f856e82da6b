"""The slab task and its vocabulary, shared by the runner and every executor.

Slabs are a pure function of (model, grid, rows): :func:`stack_slab` is the one task,
wherever it runs (:class:`SlabJob` carries what it needs). An executor
(:class:`SlabExecutor`) runs tasks: :class:`shellvox.run._runner.InProcess`,
:class:`shellvox.run._fork.ForkPool` or :class:`shellvox.run._cluster.DaskPool`;
:class:`shellvox.run._runner.SlabRunner` picks one.

With a material plan, each slab's voxels also get their materials
(:func:`shellvox.voxel.colour._materials.materials_for_slab`) in the same worker, when the halftone
is order-independent (blue noise); error diffusion runs in z order in the caller.
"""

from __future__ import annotations

import multiprocessing
import os
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour import MaterialPlan, materials_for_slab
from shellvox.voxel.geometry import layer_material_counts
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import PageEncoder
from shellvox.voxel.io.vdb import GridSpool, VdbEncoder
from shellvox.voxel.slab import SlabResult, StackModel, compute_slab
from shellvox.voxel.tray_slab import TrayStack, compute_tray_slab

#: What a slab task computes: one model, or a tray of models (tile by tile).
SlabModel = StackModel | TrayStack

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
        The slab's TIFF pages compressed, by file name
        (:class:`shellvox.voxel.io._tiff_pages.PageEncoder`), when the runner was given a page
        encoder.
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
    model: SlabModel,
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
    if isinstance(model, TrayStack):
        slab = compute_tray_slab(model, grid, z_start, z_stop)
    else:
        slab = compute_slab(model, grid, z_start, z_stop)
    materials = tally = None
    if plan is not None:
        if plan.halftone != "blue-noise":
            encoded_pages = (
                None if pages is None else pages.encode(slab.layers, slab.rgba, None, z_start)
            )
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
    encoded_pages = (
        None if pages is None else pages.encode(slab.layers, slab.rgba, materials, z_start)
    )
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


#: The voxel arrays of a slab (:class:`shellvox.voxel.slab.SlabResult`) a chunk may leave out.
SLAB_ARRAYS = ("layers", "rgba", "sdf", "sdf_band")


class SlabJob(NamedTuple):
    """What every slab task needs, sent to (or inherited by) each worker once.

    Attributes
    ----------
    model : StackModel or TrayStack
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
        (:func:`shellvox.run._chunks.encode_chunk`: the Dask wire and the checkpoints).
    """

    model: SlabModel
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
