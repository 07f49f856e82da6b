"""``build_stack``: shells, then Z slabs of layers and colours, streamed to the output files.

Numerics live in :mod:`offset` and :func:`voxel.slab.compute_slab`; the writers only
serialise. Every file is written under a temporary name and renamed only when the whole
build succeeded, ``manifest.json`` last, so a failed run leaves nothing that looks complete.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import multiprocessing
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from offset import offset_shells
from pipeline import __version__
from pipeline.build_config import BuildConfig
from pipeline.config import as_json
from pipeline.errors import ShellvoxWarning
from pipeline.mesh import ColouredMesh
from pipeline.shell_files import write_shell
from pipeline.slab_runner import SlabRunner, resolve_workers
from voxel.agreement import shell_agreement
from voxel.atomic import atomic_path
from voxel.grid import GridSpec
from voxel.nearest import SurfaceIndex
from voxel.sampler import LayerSampler
from voxel.slab import StackModel, aligned_rows
from voxel.tiff_writer import TiffStackWriter
from voxel.vdb_writer import VdbStackWriter

#: Working bytes per voxel of a slab (arrays of compute_slab, colour conversion, VDB copies).
BYTES_PER_VOXEL = 64


def build_stack(
    mesh: ColouredMesh,
    config: BuildConfig,
    out_dir: Path,
    *,
    progress: bool | None = None,
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
        ``shells/shell_k.ply`` and ``manifest.json``.
    progress : bool or None
        Show a progress bar; ``None`` shows it only on a terminal.

    Returns
    -------
    dict
        The manifest (also written to ``out_dir/manifest.json``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "manifest.json").unlink(missing_ok=True)  # the old run is no longer complete
    seconds: dict[str, float] = {}
    started = time.perf_counter()
    thickness = np.asarray(config.thickness_mm, dtype=np.float64)
    by_distance = config.layer_rule == "distance"
    half_width = config.sdf_half_width_mm
    grid = GridSpec.from_bounds(
        mesh.vertices.min(axis=0),
        mesh.vertices.max(axis=0),
        config.voxel_mm,
        margin_mm=max(config.margin_mm, half_width),
    )
    depth = np.repeat(np.cumsum(thickness)[:, None], mesh.n_faces, axis=1)
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
        rows = slab_rows_for(grid, config.slab_mb, aligned_rows(model, grid))
        # Before any other thread (shell pool, writers, progress bar) starts: the slab
        # workers are forked.
        slabs = stack.enter_context(
            SlabRunner(model, grid, rows, resolve_workers(config.workers))
        )
        if by_distance and config.shell_meshes:  # beside the voxels, in another process
            pool = stack.enter_context(multiprocessing.get_context("spawn").Pool(1))
            pending = pool.apply_async(timed_shells, (mesh.vertices, mesh.faces, thickness, config))
        sampler = LayerSampler(grid, model.n_bands, n_slabs=math.ceil(n_z / rows))
        counts = np.zeros(model.n_bands + 2, dtype=np.int64)
        diagnostics = {
            "unbalanced_rows": 0,
            "nesting_violations": 0,
            "nearest_queries": 0,
            "block_queries": 0,
        }
        manifest_path = stack.enter_context(atomic_path(out_dir / "manifest.json"))
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
        vdb = (
            VdbStackWriter(grid, sdf_half_width_mm=half_width, spool_dir=out_dir)
            if config.write_vdb
            else None
        )
        if vdb is not None:
            stack.callback(vdb.close)  # the leaf spools go, whatever happens
        vdb_path = stack.enter_context(atomic_path(out_dir / "volume.vdb")) if vdb else None
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
                shells, seconds["shells"] = pending.get()
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
            shells = [  # cleaned, float64, as read back from the files
                write_shell(stack.enter_context(atomic_path(target)), shell, target=target).shell
                for shell in shells
                for target in [out_dir / "shells" / f"shell_{shell.layer}.ply"]
            ]
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
        seconds["total"] = time.perf_counter() - started
        manifest = _manifest(mesh, config, grid, shells, counts, diagnostics, seconds)
        manifest["shell_agreement"] = agreement
        manifest["vdb"] = vdb_summary
        manifest["tiff"] = {
            "layers.tif": {"bigtiff": layers_tif.bigtiff, "samples": 1},
            "colour.tif": {"bigtiff": colour_tif.bigtiff, "samples": samples},
        }
        manifest["slab_rows"] = rows
        manifest_path.write_text(json.dumps(manifest, indent=2), encoding="utf-8")
    manifest["file_bytes"] = {
        str(path.relative_to(out_dir)): path.stat().st_size
        for path in sorted(out_dir.rglob("*"))
        if path.is_file() and not path.name.startswith(".")
    }
    return manifest


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
