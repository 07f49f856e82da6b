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
import json
import math
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from offset import offset_shells
from pipeline import __version__
from pipeline.children import ChildCall
from pipeline.config import BuildConfig, as_json
from pipeline.errors import InputError, ResourceError, ShellvoxWarning
from pipeline.estimate import BYTES_PER_VOXEL, check_resources, estimate_build
from pipeline.face_thickness import FaceThickness, thickness_summary, write_thickness_ply
from pipeline.faults import DeferredSignals
from pipeline.material_plan import build_material_plan
from pipeline.mesh import ColouredMesh
from pipeline.outdir import OutputFolder, sha256
from pipeline.printer_profile import PrinterProfile
from pipeline.shell_files import write_shell
from pipeline.slab_runner import SlabRunner, material_tally, resolve_workers
from pipeline.stack_outputs import StackOutputs
from voxel.agreement import shell_agreement
from voxel.atomic import atomic_path, write_text_atomic
from voxel.colour_report import ColourReport, sample_surface, thickness_effect
from voxel.grid import GridRangeError, GridSpec
from voxel.materials import MaterialPlan, materials_for_slab
from voxel.nearest import SurfaceIndex
from voxel.sampler import LayerSampler
from voxel.slab import SlabResult, StackModel
from voxel.srgb import codes_to_linear
from voxel.vdb_writer import VdbEncoder


def build_stack(
    mesh: ColouredMesh,
    config: BuildConfig,
    out_dir: Path,
    *,
    thickness: NDArray[np.float64] | None = None,
    faces: FaceThickness | None = None,
    profile: PrinterProfile | None = None,
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
        Output folder (created). Receives ``layers.tif``, ``colour.tif``,
        ``materials.tif``, ``volume.vdb``, ``job.gcvf``, ``shells/shell_k.ply`` and
        ``manifest.json`` (as ``config.formats`` says); the outputs of an earlier build
        there are replaced as a whole (:mod:`pipeline.outdir`).
    thickness : (K, F) float64, mm, optional
        Thickness of each layer per face (from a thickness rule); default: the constant
        ``config.thickness_mm`` for every face.
    faces : FaceThickness, optional
        The thickness rule's result behind `thickness`: written to ``thickness.ply`` and
        summarised in the manifest.
    profile : PrinterProfile, optional
        The printer's materials: with ``config.material``, every voxel gets one material
        (``materials.tif``, the job, the colour report).
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
        The manifest, exactly as written to ``out_dir/manifest.json``.

    Raises
    ------
    ResourceError
        The build cannot fit this machine (see :func:`pipeline.estimate.check_resources`).
    InputError
        The layers are deeper than the part can hold (without `force`).
    """
    out_dir = Path(out_dir)
    started = time.perf_counter()
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
    plan = None
    if profile is not None and config.material is not None:
        tick = time.perf_counter()
        plan = build_material_plan(
            profile, config.material, colour_layers=config.colour_layers, n_bands=len(depth)
        )
        # Compile (or load) the halftone kernel here, once, so the forked workers inherit
        # it instead of each loading it again.
        materials_for_slab(np.ones((1, 1, 1), np.uint8), np.zeros((1, 1, 1, 4), np.uint8), 0, plan)
        extra_seconds = {"material_plan": time.perf_counter() - tick}
    else:
        extra_seconds = {}
    job = _Job(mesh, config, grid, thickness, faces, rows, workers, profile, plan, progress)
    with OutputFolder(out_dir) as folder:
        manifest = job.run(
            out_dir, folder, started, {"estimate": dataclasses.asdict(estimate)}, extra_seconds
        )
    return manifest


@dataclasses.dataclass(frozen=True, eq=False)
class _Job:
    """Everything a build run needs, fixed before it starts."""

    mesh: ColouredMesh
    config: BuildConfig
    grid: GridSpec
    thickness: NDArray[np.float64]
    faces: FaceThickness | None
    rows: int
    workers: int
    profile: PrinterProfile | None
    plan: MaterialPlan | None
    progress: bool | None

    def run(
        self,
        out_dir: Path,
        folder: OutputFolder,
        started: float,
        extra: dict[str, Any],
        seconds: dict[str, float],
    ) -> dict[str, Any]:
        """Compute and write every slab, then the shells, the report and the manifest."""
        mesh, config, grid = self.mesh, self.config, self.grid
        depth = np.cumsum(self.thickness, axis=0)
        by_distance = config.layer_rule == "distance"
        with contextlib.ExitStack() as stack:
            shells: list[Any] | None = None
            pending = None
            if not by_distance:
                shells, seconds["shells"] = timed_shells(
                    mesh.vertices, mesh.faces, self.thickness, config
                )
            model = StackModel(
                surfaces=(
                    (mesh.vertices, mesh.faces),
                    *(((s.vertices, s.faces) for s in shells) if shells is not None else ()),
                ),
                surface=SurfaceIndex.build(mesh.vertices, mesh.faces),
                colour_at=mesh.colour_at,
                surface_colour=mesh.surface_colour(),
                colour_layers=config.colour_layers,
                sdf_half_width_mm=config.sdf_half_width_mm,
                depth_mm=depth if by_distance else None,
                layer_rule=config.layer_rule,
            )
            # the scan's regions, computed once here and inherited by the forked workers
            _ = model.surface.regions
            n_z = grid.shape_zyx[0]
            # Before any other thread (shell pool, writers, progress bar) starts: the slab
            # workers are forked.
            setup = stack.enter_context(DeferredSignals())  # no signal until all is registered
            vdb = None  # slabs of whole leaf rows can be encoded where they are computed
            whole_leaves = self.rows % 8 == 0 or self.rows >= grid.shape_zyx[0]
            halftone_here = self.plan is None or self.plan.halftone == "blue-noise"
            if config.write_vdb and whole_leaves and halftone_here:
                vdb = VdbEncoder.for_grid(  # the same grids as StackOutputs' writer
                    grid,
                    sdf_half_width_mm=config.sdf_half_width_mm,
                    material_grid=self.profile is not None and self.plan is not None,
                )
            slabs = stack.enter_context(
                SlabRunner(model, grid, self.rows, self.workers, self.plan, vdb)
            )
            if by_distance and config.shell_meshes:  # beside the voxels, in another process
                pending = stack.enter_context(  # a process that dies fails the call, not hangs
                    ChildCall(timed_shells, mesh.vertices, mesh.faces, self.thickness, config)
                )
            outputs = StackOutputs(stack, out_dir, grid, config, self.profile, self.plan)
            sampler = LayerSampler(grid, model.n_bands, n_slabs=math.ceil(n_z / self.rows))
            tally = _Tally(model.n_bands)
            report = self._colour_report()
            bar = stack.enter_context(
                tqdm(
                    total=n_z,
                    unit="z",
                    desc="voxels",
                    disable=None if self.progress is None else not self.progress,
                )
            )
            setup.close()  # a signal that came during the set-up is raised here
            tick = time.perf_counter()
            carry = None
            for item in slabs:
                slab, materials, counts, encoded = item
                if self.plan is not None and materials is None:  # error diffusion, z order
                    diffused = materials_for_slab(
                        slab.layers, slab.rgba, slab.z_start, self.plan, carry=carry
                    )
                    materials, carry = diffused.materials, diffused.carry
                    counts = material_tally(slab.layers, materials, model.n_bands + 2)
                tally.add(slab, counts)
                sampler.add(slab.z_start, slab.layers)
                if report is not None and materials is not None:
                    report.add_slab(slab.z_start, materials)
                outputs.write(slab, materials, encoded)
                bar.update(slab.z_stop - slab.z_start)
            bar.close()
            seconds["slabs"] = time.perf_counter() - tick
            tick = time.perf_counter()
            summaries = outputs.finish()
            seconds["writers_finish"] = time.perf_counter() - tick
            agreement: dict[str, Any] | None = None
            if pending is not None:
                tick = time.perf_counter()
                try:
                    shells, seconds["shells"] = pending.result()
                except Exception as error:  # the voxels do not depend on the shell meshes
                    warnings.warn(
                        f"{mesh.source}: the shell meshes failed ({error}); the voxel stack "
                        "is complete without shells/; rerun with --layers shells to see the "
                        "error",
                        ShellvoxWarning,
                        stacklevel=2,
                    )
                seconds["shells_wait"] = time.perf_counter() - tick
            written = list(outputs.written)
            if self.faces is not None:
                write_thickness_ply(out_dir / "thickness.ply", mesh, self.faces)
                written.append(out_dir / "thickness.ply")
            if shells is not None:
                (out_dir / "shells").mkdir(exist_ok=True)
                cleaned = []  # cleaned, float64, as read back from the files
                for shell in shells:
                    target = out_dir / "shells" / f"shell_{shell.layer}.ply"
                    ply = stack.enter_context(atomic_path(target))
                    cleaned.append(write_shell(ply, shell, target=target).shell)
                    written.append(target)
                shells = cleaned
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
            if tally.counts[-1] == 0 and int(tally.counts[1:].sum()) > 0:
                warnings.warn(
                    f"{mesh.source}: no voxel lies deeper than {float(depth.max()):g} mm, so "
                    "the part has no core; use a smaller --thickness if that is not what you "
                    "want",
                    ShellvoxWarning,
                    stacklevel=2,
                )
            manifest = _manifest(mesh, config, grid, self.thickness, shells, tally, seconds)
            manifest["shell_agreement"] = agreement
            manifest.update(summaries)
            manifest["slab_rows"] = self.rows
            manifest["thickness"] = (
                {"source": config.thickness_source, **thickness_summary(self.faces)}
                if self.faces is not None
                else {"source": config.thickness_source}
            )
            if self.profile is not None and self.plan is not None:
                manifest["printer"] = self.profile.name
                manifest["materials"] = tally.materials(self.profile)
                manifest["material_voxels_per_layer"] = tally.per_layer(self.profile)
            if report is not None:
                tick = time.perf_counter()
                manifest["colour_report"] = self._report_result(report)
                seconds["colour_report"] = time.perf_counter() - tick
            manifest.update(extra)
        # Every file is in place (renamed when the stack closed); the manifest comes last.
        manifest["files"] = folder.commit(written)
        seconds["total"] = time.perf_counter() - started
        write_text_atomic(out_dir / "manifest.json", json.dumps(manifest, indent=2))
        return manifest

    def _report_result(self, report: ColourReport) -> dict[str, Any]:
        """Return the measured report and what the thickness changes (optical model)."""
        assert self.plan is not None and self.profile is not None
        result = report.result()
        samples = report.samples
        display = np.array([m.display_srgb for m in self.profile.materials], dtype=np.uint8)
        linear = codes_to_linear(display).astype(np.float64)
        share = self.plan.separation.proportions(samples.target_rgba).astype(np.float64)
        ideal = share @ linear[list(self.plan.column_materials)]
        colour_depth = np.cumsum(self.thickness, axis=0)[max(self.config.colour_layers) - 1]
        area = face_areas(self.mesh)
        result["thickness_effect"] = thickness_effect(
            samples.target_rgba,
            ideal,
            linear[self.plan.backing_material],
            colour_depth[samples.face_ids],
            float(np.average(colour_depth, weights=area)),
            self.config.optical_depth_mm,
        )
        return result

    def _colour_report(self) -> ColourReport | None:
        if self.profile is None or self.plan is None or self.config.report_samples == 0:
            return None
        samples = sample_surface(
            self.mesh.vertices,
            self.mesh.faces,
            self.mesh.colour_at,
            self.config.report_samples,
            seed=0,
        )
        display = np.zeros((len(self.profile.materials), 3), dtype=np.uint8)
        for material in self.profile.materials:
            display[material.index] = material.display_srgb
        return ColourReport(
            samples, self.grid, display, optical_depth_mm=self.config.optical_depth_mm
        )


class _Tally:
    """Voxels per layer, per layer and material, and the slabs' diagnostics."""

    def __init__(self, n_bands: int) -> None:
        self.n_layers = n_bands + 2
        self.counts = np.zeros(self.n_layers, dtype=np.int64)
        self.by_material = np.zeros((self.n_layers, 256), dtype=np.int64)
        self.diagnostics = {
            "unbalanced_rows": 0,
            "nesting_violations": 0,
            "nearest_queries": 0,
            "distance_tests": 0,
        }

    def add(self, slab: SlabResult, by_material: NDArray[np.int64] | None) -> None:
        """Count a slab; `by_material` is its (layers, 256) tally when it has materials."""
        if by_material is not None:  # counted in the worker
            self.by_material += by_material
            self.counts += by_material.sum(axis=1)
        else:
            self.counts += slab.layer_counts
        self.diagnostics["unbalanced_rows"] += slab.n_unbalanced_rows
        self.diagnostics["nesting_violations"] += slab.n_nesting_violations
        self.diagnostics["nearest_queries"] += slab.n_nearest_queries
        self.diagnostics["distance_tests"] += slab.n_distance_tests

    def materials(self, profile: PrinterProfile) -> list[dict[str, Any]]:
        totals = self.by_material.sum(axis=0)
        return [
            {
                "index": m.index,
                "name": m.name,
                "role": m.role,
                "rgba_key": list(m.rgba_key),
                "display_srgb": list(m.display_srgb),
                "voxels": int(totals[m.index]),
            }
            for m in profile.materials
            if totals[m.index] > 0 or m.index == 0
        ]

    def per_layer(self, profile: PrinterProfile) -> dict[str, dict[str, int]]:
        return {
            str(layer): {
                profile.materials[index].name: int(count)
                for index, count in enumerate(row)
                if count and index < len(profile.materials)
            }
            for layer, row in enumerate(self.by_material)
        }


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


def face_areas(mesh: ColouredMesh) -> NDArray[np.float64]:
    """Return the area of every face ``(F,) float64``, mm^2."""
    corners = mesh.vertices[mesh.faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas: NDArray[np.float64] = 0.5 * np.linalg.norm(cross, axis=1)
    return areas


def mesh_area(mesh: ColouredMesh) -> float:
    """Return the surface area of the model, mm^2."""
    return float(face_areas(mesh).sum())


def check_depth(
    mesh: ColouredMesh, depth: NDArray[np.float64], *, force: bool, source: str = "--thickness"
) -> None:
    """Refuse layers deeper than half the part's smallest extent (no core could remain).

    Parameters
    ----------
    depth : (K, F) float64, mm
        Cumulative depth of each layer per face.
    source : str
        Where the thickness came from (named in the message).
    """
    extent = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    limit = 0.5 * float(extent.min())
    total = float(depth[-1].min())
    if total >= limit and not force:
        option = "--thickness" if source == "--thickness" else f"--thickness-rule ({source})"
        raise InputError(
            option,
            f"the layers reach at least {total:g} mm deep but {mesh.source or 'the model'} is "
            f"only {2 * limit:g} mm thick at its thinnest extent, so every voxel would be in "
            "a layer and none in the core",
            f"use layers thinner than {limit:g} mm in all (e.g. --thickness "
            f"{limit / 3:.2g},{limit / 3:.2g}), or --force",
        )


def _manifest(
    mesh: ColouredMesh,
    config: BuildConfig,
    grid: GridSpec,
    thickness: NDArray[np.float64],
    shells: list[Any] | None,
    tally: _Tally,
    seconds: dict[str, float],
) -> dict[str, Any]:
    n_bands = len(thickness)
    depth = np.cumsum(thickness, axis=0)
    how = (
        " (exact nearest-point distance)"
        if config.layer_rule == "distance"
        else " (between offset shells)"
    )
    layers: list[dict[str, Any]] = [
        {"index": 0, "name": "outside", "thickness_rule": "outside the model"}
    ]
    for k in range(1, n_bands + 1):
        role = "colour" if k in config.colour_layers else "backing"
        t, d = thickness[k - 1], depth[k - 1]
        constant = bool(np.all(t == t[0]))
        rule = (
            f"{t[0]:g} mm thick: distance to the surface from {d[0] - t[0]:g} to {d[0]:g} mm"
            if constant
            else f"{t.min():g} to {t.max():g} mm thick per face (median {np.median(t):g} mm): "
            "distance to the surface between the depths of the nearest face"
        )
        layers.append(
            {
                "index": k,
                "name": f"{role}_{k}",
                "thickness_mm": float(np.median(t)),
                "depth_mm": float(np.median(d)),
                "thickness_per_face_mm": _stats(t),
                "depth_per_face_mm": _stats(d),
                "thickness_rule": rule + how,
                "shell_faces": None if shells is None else len(shells[k - 1].faces),
            }
        )
    layers.append(
        {
            "index": n_bands + 1,
            "name": "core",
            "thickness_rule": f"deeper than the last layer ({depth[-1].min():g} to "
            f"{depth[-1].max():g} mm)",
        }
    )
    for entry in layers:
        entry["voxels"] = int(tally.counts[entry["index"]])
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
        "diagnostics": tally.diagnostics,
        "seconds": seconds,
    }


def _stats(values: NDArray[np.float64]) -> dict[str, float]:
    """Summary statistics of per-face values (mm)."""
    return {
        "min": float(values.min()),
        "p05": float(np.percentile(values, 5)),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "max": float(values.max()),
        "mean": float(values.mean()),
    }


def _sha256(source: str) -> str | None:
    """SHA-256 of the input file, or None when the mesh came from no file."""
    path = Path(source)
    return sha256(path) if source and path.is_file() else None


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


def slab_rows_for(grid: GridSpec, slab_mb: float, align: int = 8) -> int:
    """Return the slab height (rows) whose working arrays fit ``slab_mb`` MiB.

    A multiple of ``align`` rows (the VDB leaf height: slabs then need no regrouping)
    where the budget holds at least that many.
    """
    per_row = grid.shape_zyx[1] * grid.shape_zyx[2] * BYTES_PER_VOXEL
    rows = max(1, math.floor(slab_mb * 2**20 / per_row))
    return rows - rows % align if rows >= align else rows
