"""A build's plan, fixed before anything is allocated: grid, layers, slabs, workers, cost.

:func:`plan_build` checks the thickness, lays the voxel grid over the model (its bounds
plus the margin), refuses layers deeper than the part can hold, sizes the Z slabs to the
memory budget and the workers to the slabs, and refuses a build the estimate says cannot
fit (:mod:`shellvox.stack._estimate`), all before the output folder is touched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.config import BuildConfig
from shellvox.errors import InputError, ResourceError, opt
from shellvox.model import ColouredMesh, face_areas
from shellvox.offset import METHODS, ShellCost, automatic_lattice, lattice_cell_mm
from shellvox.run import resolve_workers
from shellvox.stack._estimate import (
    BYTES_PER_VOXEL,
    BuildEstimate,
    check_resources,
    estimate_build,
    report_sample_count,
    store_buffer_rows,
)
from shellvox.voxel.grid import GridRangeError, GridSpec


@dataclass(frozen=True, eq=False)
class BuildPlan:
    """What a build run needs, fixed before it starts.

    Attributes
    ----------
    grid : GridSpec
        The voxel grid.
    thickness : (K, F) float64, mm
        Thickness of each layer per face.
    depth : (K, F) float64, mm
        Cumulative depth of each layer per face.
    rows : int
        Slab height (grid rows).
    workers : int
        Processes computing slabs.
    estimate : BuildEstimate
        Memory, disk and time the build is expected to take.
    """

    grid: GridSpec
    thickness: NDArray[np.float64]
    depth: NDArray[np.float64]
    rows: int
    workers: int
    estimate: BuildEstimate


def plan_build(
    mesh: ColouredMesh,
    config: BuildConfig,
    out_dir: Path,
    *,
    thickness: NDArray[np.float64] | None = None,
    force: bool = False,
) -> BuildPlan:
    """Return the plan of a build, or refuse it (see the module).

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, outward-oriented model in mm.
    config : BuildConfig
        Grid, layers and resources.
    out_dir : Path
        Output folder (its file system must hold the estimated files).
    thickness : (K, F) float64, mm, optional
        Thickness of each layer per face; default ``config.thickness_mm`` on every face.
    force : bool
        Plan even when the estimate says memory or disk will not suffice, or the layers
        leave no core.

    Raises
    ------
    ValueError
        `thickness` of the wrong shape or not positive.
    InputError
        The layers are deeper than the part can hold (without `force`).
    ResourceError
        The build cannot fit this machine (see :func:`shellvox.stack._estimate.check_resources`).
    """
    if thickness is None:
        thickness = np.repeat(
            np.asarray(config.thickness_mm, dtype=np.float64)[:, None], mesh.n_faces, axis=1
        )
    thickness = np.asarray(thickness, dtype=np.float64)
    if thickness.shape != (len(config.thickness_mm), mesh.n_faces) or not np.all(thickness > 0):
        raise ValueError(
            f"thickness must be positive, ({len(config.thickness_mm)}, {mesh.n_faces}) "
            f"(one row per layer of config.thickness_mm), got shape {thickness.shape}"
        )
    depth = np.cumsum(thickness, axis=0)
    grid = grid_for(mesh, config)
    check_depth(mesh, depth, force=force, source=config.thickness_source)
    workers = resolve_workers(config.workers)
    rows = slab_rows_for(grid, config.slab_mb)
    area = float(face_areas(mesh.vertices, mesh.faces).sum())
    estimate = estimate_build(
        grid.shape_zyx,
        grid.voxel_mm,
        bands=[
            (
                area,
                max(float(depth.max()), config.sdf_half_width_mm),
            )
        ],
        n_faces=mesh.n_faces,
        slab_rows=rows,
        workers=min(workers, -(-grid.shape_zyx[0] // rows)),
        shells=shell_cost(config, grid, mesh.n_faces, area, len(thickness)),
        store_rows=store_buffer_rows(config.formats, rows),
        report_samples=(
            report_sample_count(area, config.report_samples, config.proof_density)
            if config.material is not None
            else 0
        ),
    )
    check_resources(estimate, out_dir, force=force)
    return BuildPlan(grid, thickness, depth, rows, workers, estimate)


def shell_cost(
    config: BuildConfig, grid: GridSpec, n_faces: int, area_mm2: float, layers: int
) -> ShellCost | None:
    """Return the estimated cost of a build's offset shells (None: it makes none).

    The ``field`` shells of the distance rule are meshed from the voxels' nodes, so their
    step is the node lattice's cell (:func:`~shellvox.offset.automatic_lattice`); with the
    ``"shells"`` rule they are made first at the automatic step.
    """
    if not (config.shell_meshes or config.layer_rule == "shells"):
        return None
    step: float | None = None
    if config.shell_method == "field" and config.layer_rule == "distance":
        step = lattice_cell_mm(grid, automatic_lattice(grid, area_mm2, layers))
    return METHODS[config.shell_method].cost(n_faces, area_mm2, layers, step)


def grid_for(mesh: ColouredMesh, config: BuildConfig) -> GridSpec:
    """Return the voxel grid of a build: the model's bounds plus the margin."""
    try:
        return GridSpec.from_bounds(
            mesh.vertices.min(axis=0),
            mesh.vertices.max(axis=0),
            config.voxel_mm,
            margin_mm=max(config.margin_mm, config.sdf_half_width_mm),
        )
    except GridRangeError as error:
        raise ResourceError(
            opt("voxel_size"),
            str(error),
            f"pass sizes in mm such as {opt('voxel_size', (0.05, 0.05, 0.03))}; check "
            f"{opt('scale')}",
        ) from None


def check_depth(
    mesh: ColouredMesh, depth: NDArray[np.float64], *, force: bool, source: str = "--thickness"
) -> None:
    """Refuse layers deeper than half the part's smallest extent (no core could remain).

    Parameters
    ----------
    mesh : ColouredMesh
        The model.
    depth : (K, F) float64, mm
        Cumulative depth of each layer per face.
    force : bool
        Do not refuse.
    source : str
        Where the thickness came from (named in the message).
    """
    extent = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    limit = 0.5 * float(extent.min())
    total = float(depth[-1].min())
    if total >= limit and not force:
        option = (
            opt("thickness") if source == "--thickness" else f"{opt('thickness_rule')} ({source})"
        )
        each = float(f"{limit / 3:.2g}")
        raise InputError(
            option,
            f"the layers reach at least {total:g} mm deep but {mesh.source or 'the model'} is "
            f"only {2 * limit:g} mm thick at its thinnest extent, so every voxel would be in "
            "a layer and none in the core",
            f"use layers thinner than {limit:g} mm in all (e.g. "
            f"{opt('thickness', (each, each))}), or {opt('force_run')}",
        )


def slab_rows_for(grid: GridSpec, slab_mb: float, align: int = 8) -> int:
    """Return the slab height (rows) whose working arrays fit ``slab_mb`` MiB.

    A multiple of ``align`` rows (the VDB leaf height: slabs then need no regrouping)
    where the budget holds at least that many.

    Examples
    --------
    >>> grid = GridSpec((0.0, 0.0, 0.0), (0.1, 0.1, 0.1), (100, 64, 64))  # 192 kB a row
    >>> slab_rows_for(grid, 1.0), slab_rows_for(grid, 2.0), slab_rows_for(grid, 0.1)
    (5, 8, 1)
    """
    per_row = grid.shape_zyx[1] * grid.shape_zyx[2] * BYTES_PER_VOXEL
    rows = max(1, math.floor(slab_mb * 2**20 / per_row))
    return rows - rows % align if rows >= align else rows
