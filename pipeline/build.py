"""``build_stack``: shells, then Z slabs of layers and colours, streamed to the output files.

Numerics live in :mod:`offset` and :func:`voxel.slab.compute_slab`; the writers only
serialise. Every file is written under a temporary name and renamed only when the whole
build succeeded, ``manifest.json`` last (with every file's size and SHA-256), so a failed
run leaves nothing that looks complete; the output folder is locked and an older build in
it is replaced as a whole (:mod:`pipeline.outdir`). The cost is estimated, and a build
that cannot fit refused, before anything is allocated (:mod:`pipeline.estimate`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from tqdm import tqdm

from offset import offset_shells
from pipeline import __version__
from pipeline.build_config import BuildConfig
from pipeline.children import ChildCall
from pipeline.config import as_json
from pipeline.errors import InputError, ResourceError, ShellvoxWarning
from pipeline.estimate import BYTES_PER_VOXEL, check_resources, estimate_build
from pipeline.faults import DeferredSignals
from pipeline.mesh import ColouredMesh
from pipeline.outdir import OutputFolder
from pipeline.slab_runner import SlabRunner, resolve_workers
from voxel.agreement import shell_agreement
from voxel.atomic import atomic_path, write_text_atomic
from voxel.blocks import COARSE, fine_block_size
from voxel.grid import GridRangeError, GridSpec
from voxel.nearest import SurfaceIndex
from voxel.sampler import LayerSampler
from voxel.slab import StackModel
from voxel.tiff_writer import TiffStackWriter
from voxel.vdb_writer import VdbStackWriter


def build_stack(
    mesh: ColouredMesh,
    config: BuildConfig,
    out_dir: Path,
    *,
    progress: bool | None = None,
    force: bool = False,
    say: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Build the layered voxel stack of a coloured mesh into ``out_dir``.

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, outward-oriented model in mm.
    config : BuildConfig
        Grid, layers and output options.
    out_dir : Path
        Output folder (created). Receives ``layers.tif``, ``colour.tif``, ``volume.vdb``,
        ``shells/shell_k.ply`` and ``manifest.json``; the outputs of an earlier build there
        are replaced as a whole (:mod:`pipeline.outdir`).
    progress : bool or None
        Show a progress bar; ``None`` shows it only on a terminal.
    force : bool
        Build even when the estimate says memory or disk will not suffice, or the layers
        leave no core.
    say : callable, optional
        Receives one line with the cost estimate before any work starts.

    Returns
    -------
    dict
        The manifest, as written to ``out_dir/manifest.json``.

    Raises
    ------
    ResourceError
        The build cannot fit this machine (see :func:`pipeline.estimate.check_resources`).
    InputError
        The layers are deeper than the part can hold (without `force`).
    """
    out_dir = Path(out_dir)
    started = time.perf_counter()
    grid = grid_for(mesh, config)
    check_depth(mesh, config, force=force)
    workers = resolve_workers(config.workers)
    depth = np.repeat(np.cumsum(config.thickness_mm)[:, None], mesh.n_faces, axis=1)
    # the rows of a coarse block (voxel.slab.aligned_rows): whole ones waste no block queries
    reach = config.sdf_half_width_mm
    if config.layer_rule == "distance":
        reach = max(float(depth.max()), reach)
    rows_align = fine_block_size(grid, reach)[0] * COARSE if reach > 0 else 1
    rows = slab_rows_for(grid, config.slab_mb, rows_align)
    estimate = estimate_build(
        grid.shape_zyx,
        grid.voxel_mm,
        area_mm2=mesh_area(mesh),
        reach_mm=max(float(depth.max()), config.sdf_half_width_mm),
        n_faces=mesh.n_faces,
        slab_rows=rows,
        workers=min(workers, -(-grid.shape_zyx[0] // rows)),
    )
    check_resources(estimate, out_dir, force=force)
    if say is not None:
        say(estimate.line())
    with OutputFolder(out_dir) as folder:
        manifest = _build(mesh, config, grid, depth, rows, workers, out_dir, progress, folder)
    manifest["seconds"]["total"] = time.perf_counter() - started
    manifest["estimate"] = dataclasses.asdict(estimate)
    return manifest


def _build(
    mesh: ColouredMesh,
    config: BuildConfig,
    grid: GridSpec,
    depth: np.ndarray[Any, Any],
    rows: int,
    workers: int,
    out_dir: Path,
    progress: bool | None,
    folder: OutputFolder,
) -> dict[str, Any]:
    seconds: dict[str, float] = {}
    thickness = np.asarray(config.thickness_mm, dtype=np.float64)
    by_distance = config.layer_rule == "distance"
    half_width = config.sdf_half_width_mm
    written: list[Path] = []
    with contextlib.ExitStack() as stack:
        shells: list[Any] | None = None
        pending = None
        if not by_distance:
            shells, seconds["shells"] = timed_shells(mesh.vertices, mesh.faces, thickness, config)
        model = StackModel(
            surfaces=(
                (mesh.vertices, mesh.faces),
                *(((s.vertices, s.faces) for s in shells) if shells is not None else ()),
            ),
            surface=SurfaceIndex.build(mesh.vertices, mesh.faces),
            colour_at=mesh.colour_at,
            colour_layers=config.colour_layers,
            sdf_half_width_mm=half_width,
            depth_mm=depth if by_distance else None,
        )
        n_z = grid.shape_zyx[0]
        # Before any other thread (shell pool, writers, progress bar) starts: the slab
        # workers are forked.
        setup = stack.enter_context(DeferredSignals())  # no signal until all is registered
        slabs = stack.enter_context(SlabRunner(model, grid, rows, workers))
        if by_distance and config.shell_meshes:  # beside the voxels, in another process
            pending = stack.enter_context(  # a process that dies fails the call, not hangs
                ChildCall(timed_shells, mesh.vertices, mesh.faces, thickness, config)
            )
        sampler = LayerSampler(grid, model.n_bands, n_slabs=math.ceil(n_z / rows))
        counts = np.zeros(model.n_bands + 2, dtype=np.int64)
        diagnostics = {
            "unbalanced_rows": 0,
            "nesting_violations": 0,
            "nearest_queries": 0,
            "block_queries": 0,
        }
        samples = 4 if config.alpha else 3
        level = config.compression_level
        layers_tif = stack.enter_context(
            TiffStackWriter(
                stack.enter_context(atomic_path(out_dir / "layers.tif")),
                grid,
                compression_level=level,
            )
        )
        colour_tif = stack.enter_context(
            TiffStackWriter(
                stack.enter_context(atomic_path(out_dir / "colour.tif")),
                grid,
                samples=samples,
                compression_level=level,
            )
        )
        written += [out_dir / "layers.tif", out_dir / "colour.tif"]
        vdb = (
            VdbStackWriter(grid, sdf_half_width_mm=half_width, spool_dir=out_dir)
            if config.write_vdb
            else None
        )
        if vdb is not None:
            stack.callback(vdb.close)  # the leaf spools go, whatever happens
        vdb_path = stack.enter_context(atomic_path(out_dir / "volume.vdb")) if vdb else None
        if vdb is not None:
            written.append(out_dir / "volume.vdb")
        bar = stack.enter_context(
            tqdm(
                total=n_z,
                unit="z",
                desc="voxels",
                disable=None if progress is None else not progress,
            )
        )
        is_colour_layer = np.zeros(256, dtype=bool)
        is_colour_layer[list(config.colour_layers)] = True
        setup.close()  # a signal that came during the set-up is raised here
        tick = time.perf_counter()
        for slab in slabs:
            counts += np.bincount(slab.layers.ravel(), minlength=len(counts))[: len(counts)]
            sampler.add(slab.z_start, slab.layers)
            diagnostics["unbalanced_rows"] += slab.n_unbalanced_rows
            diagnostics["nesting_violations"] += slab.n_nesting_violations
            diagnostics["nearest_queries"] += slab.n_nearest_queries
            diagnostics["block_queries"] += slab.n_block_queries
            layers_tif.write_slab(slab.layers)
            colour_tif.write_slab(slab.rgba[..., :samples])
            if vdb is not None:
                coloured = is_colour_layer[slab.layers]
                vdb.write_slab(slab.z_start, slab.layers, slab.rgba[..., :3], coloured, slab.sdf)
            bar.update(slab.z_stop - slab.z_start)
        bar.close()
        seconds["slabs"] = time.perf_counter() - tick
        tick = time.perf_counter()
        layers_tif.close()
        colour_tif.close()
        seconds["tiff_finish"] = time.perf_counter() - tick
        vdb_summary: dict[str, Any] = {}
        if vdb is not None and vdb_path is not None:
            tick = time.perf_counter()
            vdb_summary = vdb.write(vdb_path, {"creator": f"shellvox {__version__}"})
            seconds["vdb_write"] = time.perf_counter() - tick
        agreement: dict[str, Any] | None = None
        if pending is not None:
            tick = time.perf_counter()
            try:
                shells, seconds["shells"] = pending.result()
            except Exception as error:  # the voxels do not depend on the shell meshes
                warnings.warn(
                    f"{mesh.source}: the shell meshes failed ({error}); the voxel stack is "
                    "complete without shells/; rerun with --layers shells to see the error",
                    ShellvoxWarning,
                    stacklevel=2,
                )
            seconds["shells_wait"] = time.perf_counter() - tick
        if shells is not None:
            (out_dir / "shells").mkdir(exist_ok=True)
            for shell in shells:
                target = out_dir / "shells" / f"shell_{shell.layer}.ply"
                ply = stack.enter_context(atomic_path(target))
                trimesh.Trimesh(shell.vertices, shell.faces, process=False).export(
                    str(ply), file_type="ply"
                )
                written.append(target)
            if by_distance:
                tick = time.perf_counter()
                points, sampled = sampler.samples()
                agreement = shell_agreement(
                    points,
                    sampled,
                    model.surface,
                    depth,
                    [(s.vertices, s.faces) for s in shells],
                    clear_mm=float(np.linalg.norm(grid.voxel_mm)),
                )
                seconds["agreement"] = time.perf_counter() - tick
        if counts[-1] == 0 and int(counts[1:].sum()) > 0:
            warnings.warn(
                f"{mesh.source}: no voxel lies deeper than {float(depth.max()):g} mm, so the "
                "part has no core; use a smaller --thickness if that is not what you want",
                ShellvoxWarning,
                stacklevel=2,
            )
        manifest = _manifest(mesh, config, grid, shells, counts, diagnostics, seconds)
        manifest["shell_agreement"] = agreement
        manifest["vdb"] = vdb_summary
        manifest["tiff"] = {
            "layers.tif": {"bigtiff": layers_tif.bigtiff, "samples": 1},
            "colour.tif": {"bigtiff": colour_tif.bigtiff, "samples": samples},
        }
        manifest["slab_rows"] = rows
    # Every file is in place (renamed when the stack closed); the manifest comes last.
    manifest["files"] = folder.commit(written)
    write_text_atomic(out_dir / "manifest.json", json.dumps(manifest, indent=2))
    return manifest


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
            "--voxel-size", str(error), "pass sizes in mm such as 0.05,0.05,0.03; check --scale"
        ) from None


def mesh_area(mesh: ColouredMesh) -> float:
    """Return the surface area of the model, mm^2."""
    corners = mesh.vertices[mesh.faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return float(0.5 * np.linalg.norm(cross, axis=1).sum())


def check_depth(mesh: ColouredMesh, config: BuildConfig, *, force: bool) -> None:
    """Refuse layers deeper than half the part's smallest extent (no core could remain)."""
    extent = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    limit = 0.5 * float(extent.min())
    total = float(sum(config.thickness_mm))
    if total >= limit and not force:
        raise InputError(
            "--thickness",
            f"the layers reach {total:g} mm deep but {mesh.source or 'the model'} is only "
            f"{2 * limit:g} mm thick at its thinnest extent, so every voxel would be in a "
            "layer and none in the core",
            f"use layers thinner than {limit:g} mm in all, or --force",
        )


def _manifest(
    mesh: ColouredMesh,
    config: BuildConfig,
    grid: GridSpec,
    shells: list[Any] | None,
    counts: np.ndarray[Any, Any],
    diagnostics: dict[str, int],
    seconds: dict[str, float],
) -> dict[str, Any]:
    n_bands = len(config.thickness_mm)
    depth = np.cumsum(config.thickness_mm)
    layers: list[dict[str, Any]] = [
        {"index": 0, "name": "outside", "thickness_rule": "outside the model"}
    ]
    for k in range(1, n_bands + 1):
        role = "colour" if k in config.colour_layers else "backing"
        layers.append(
            {
                "index": k,
                "name": f"{role}_{k}",
                "thickness_mm": config.thickness_mm[k - 1],
                "depth_mm": float(depth[k - 1]),
                "thickness_rule": (
                    f"{config.thickness_mm[k - 1]} mm thick: distance to the surface from "
                    f"{depth[k - 1] - config.thickness_mm[k - 1]:g} to {depth[k - 1]:g} mm"
                    + (
                        " (exact nearest-point distance)"
                        if config.layer_rule == "distance"
                        else " (between offset shells)"
                    )
                ),
                "shell_faces": None if shells is None else len(shells[k - 1].faces),
            }
        )
    layers.append(
        {
            "index": n_bands + 1,
            "name": "core",
            "thickness_rule": f"deeper than {depth[-1]:g} mm",
        }
    )
    for entry in layers:
        entry["voxels"] = int(counts[entry["index"]])
        entry["colour"] = entry["index"] in config.colour_layers
    return {
        "tool": f"shellvox {__version__}",
        "input": {"path": mesh.source, "sha256": _sha256(mesh.source), "faces": mesh.n_faces},
        "config": as_json(config),
        "grid": {
            "shape_zyx": list(grid.shape_zyx),
            "voxel_size_mm": list(grid.voxel_mm),
            "origin_mm": list(grid.origin_mm),
            "convention": "voxel (z, y, x) centre = origin_mm + (x*vx, y*vy, z*vz)",
        },
        "layers": layers,
        "voxel_counts": {entry["name"]: entry["voxels"] for entry in layers},
        "diagnostics": diagnostics,
        "seconds": seconds,
    }


def _sha256(source: str) -> str | None:
    path = Path(source)
    if not source or not path.is_file():
        return None
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def timed_shells(
    vertices: np.ndarray[Any, Any],
    faces: np.ndarray[Any, Any],
    thickness: np.ndarray[Any, Any],
    config: BuildConfig,
) -> tuple[list[Any], float]:
    """Return the offset shells of the model and the seconds they took (picklable)."""
    tick = time.perf_counter()
    shells = offset_shells(vertices, faces, thickness, method=config.shell_method)
    return shells, time.perf_counter() - tick


def slab_rows_for(grid: GridSpec, slab_mb: float, align: int = 1) -> int:
    """Return the slab height (rows) whose working arrays fit ``slab_mb`` MiB.

    Rounded down to a multiple of ``align`` rows where the budget holds at least that many.
    """
    per_row = grid.shape_zyx[1] * grid.shape_zyx[2] * BYTES_PER_VOXEL
    rows = max(1, math.floor(slab_mb * 2**20 / per_row))
    return rows - rows % align if rows >= align else rows
