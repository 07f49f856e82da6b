"""``build_stack``: shells, then Z slabs of layers and colours, streamed to the output files.

Numerics live in :mod:`offset` and :func:`shellvox.voxel.slab.compute_slab`; the writers only
serialise. The parts of a build:

- :mod:`shellvox.stack._plan` the grid, slabs and workers, and the cost estimate: a build
  that cannot fit is refused before anything is allocated;
- :mod:`shellvox.stack._shell_job` the offset shells, before the voxels or beside them;
- :mod:`shellvox.run._runner` the slabs, here, in forked workers or on a Dask cluster,
  and :mod:`shellvox.output._streams` the streaming writers they feed;
- :mod:`shellvox.run._checkpoints` the checkpoints of finished slabs, so a killed build can
  be resumed;
- :mod:`shellvox.output._folder` the output folder: every file under a temporary name,
  renamed only when the whole build succeeded, ``manifest.json`` last (assembled by
  :mod:`shellvox.output._manifest`, with every file's size and SHA-256), so a failed run
  leaves nothing that looks complete (:mod:`shellvox.output._outdir`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from shellvox.config import BuildConfig
from shellvox.errors import opt, warn
from shellvox.faults import DeferredSignals
from shellvox.model import ColouredMesh
from shellvox.offset.shells import Shell
from shellvox.output import (
    BuildFolder,
    StackOutputs,
    Tally,
    gcvf_slices,
    stack_manifest,
    zarr_shards,
)
from shellvox.printer import PrinterProfile, build_material_plan
from shellvox.run import SLAB_ARRAYS, RunFolder, RunSettings, SlabRunner, material_tally, run_key
from shellvox.stack._colour_check import ColourCheck
from shellvox.stack._plan import BuildPlan, plan_build
from shellvox.stack._progress import progress_bar
from shellvox.stack._running import run_job, settle_running
from shellvox.stack._shell_job import ShellJob
from shellvox.thickness import FaceThickness
from shellvox.voxel.agreement import shell_agreement
from shellvox.voxel.colour import MaterialPlan, materials_for_slab
from shellvox.voxel.geometry import NodeLattice, SurfaceIndex, soup_solid
from shellvox.voxel.io import PageEncoder
from shellvox.voxel.io.vdb import VdbEncoder
from shellvox.voxel.sampler import LayerSampler
from shellvox.voxel.slab import StackModel


def build_stack(
    mesh: ColouredMesh,
    config: BuildConfig,
    out_dir: Path,
    *,
    thickness: np.ndarray[Any, np.dtype[np.float64]] | None = None,
    faces: FaceThickness | None = None,
    profile: PrinterProfile | None = None,
    progress: bool | None = None,
    force: bool = False,
    say: Callable[[str], None] | None = None,
    running: RunSettings | None = None,
) -> dict[str, Any]:
    """Build the layered voxel stack of a coloured mesh into ``out_dir``.

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, outward-oriented model in mm.
    config : BuildConfig
        Grid, layers and output options.
    out_dir : Path
        Output folder (created): ``layers.tif``, ``colour.tif``, ``materials.tif``,
        ``volume.vdb``, ``job.gcvf``, ``shells/``, ``manifest.json`` as ``config`` says;
        an earlier build there is replaced as a whole.
    thickness : (K, F) float64, mm, optional
        Thickness of each layer per face; default ``config.thickness_mm`` on every face.
    faces : FaceThickness, optional
        The thickness rule's result behind `thickness` (``thickness.ply``, manifest).
    profile : PrinterProfile, optional
        With ``config.material``: one material per voxel (``materials.tif``, the job and
        the colour report).
    progress : bool or None
        Show the progress bars; ``None``: where a person is watching
        (:func:`shellvox.stack._progress.watched`).
    force : bool
        Build even when the estimate says it will not fit, or the layers leave no core.
    say : callable, optional
        Receives one line with the cost estimate before any work starts.
    running : RunSettings, optional
        Where the slabs run (``workers``, or a Dask scheduler), checkpoints and resume
        (:mod:`shellvox.run._checkpoints`); default: this machine, with checkpoints.

    Returns
    -------
    dict
        The manifest, exactly as written to ``out_dir/manifest.json``.
    """
    started = time.perf_counter()
    plan = plan_build(mesh, config, Path(out_dir), thickness=thickness, force=force)
    if say is not None:
        say(plan.estimate.line())
    materials, seconds = _material_plan(profile, config, len(plan.depth))
    running = settle_running(running, plan)
    key = run_key(mesh, config, plan.grid, plan.rows, plan.thickness, (profile, materials))
    job = _Job(mesh, config, plan, faces, profile, materials, progress, seconds, running)
    return run_job(job, Path(out_dir), key, started)


def stack_model(
    mesh: ColouredMesh,
    config: BuildConfig,
    depth: np.ndarray[Any, np.dtype[np.float64]] | None,
    shells: list[Shell] | None = None,
    lattice: NodeLattice | None = None,
) -> StackModel:
    """Return what every slab of `mesh` needs, its scan regions computed (before forking).

    `depth` ``(K, F) float64`` mm: the distance layers' depths (None with the "shells"
    rule, whose `shells` give the layers); `lattice`: the voxel centres whose layer field
    the slabs keep for the shell meshes.
    """
    solid = mesh.solid
    # the inside: the mesh's faces, or all the faces of its solid (exactly, when closed)
    outer = (mesh.vertices, mesh.faces)
    if solid is not None and solid.closed:
        outer = (solid.vertices, solid.faces)
    model = StackModel(
        surfaces=(
            outer,
            *(((s.vertices, s.faces) for s in shells) if shells is not None else ()),
        ),
        surface=SurfaceIndex.build(mesh.vertices, mesh.faces),
        colour_at=mesh.colour_at,
        surface_colour=mesh.surface_colour(),
        colour_layers=config.colour_layers,
        sdf_half_width_mm=config.sdf_half_width_mm,
        depth_mm=depth,
        layer_rule=config.layer_rule,
        field_nodes=lattice,
        solid=None if solid is None else soup_solid(solid.vertices, solid.faces),
        solid_closed=solid is not None and solid.closed,
        partly=None if solid is None else solid.partly,
    )
    _ = model.surface.regions  # the scan's regions, computed once, inherited by workers
    return model


def _material_plan(
    profile: PrinterProfile | None, config: BuildConfig, n_bands: int
) -> tuple[MaterialPlan | None, Mapping[str, float]]:
    """Return the separation and halftone of the build (None: no materials), and its seconds."""
    if profile is None or config.material is None:
        return None, {}
    tick = time.perf_counter()
    plan = build_material_plan(
        profile, config.material, colour_layers=config.colour_layers, n_bands=n_bands
    )
    # Compile (or load) the halftone kernel here, once, so the forked workers inherit it
    # instead of each loading it again.
    materials_for_slab(np.ones((1, 1, 1), np.uint8), np.zeros((1, 1, 1, 4), np.uint8), 0, plan)
    return plan, {"material_plan": time.perf_counter() - tick}


@dataclass(frozen=True, eq=False)
class _Job:
    """Everything a build run needs, fixed before it starts."""

    mesh: ColouredMesh
    config: BuildConfig
    plan: BuildPlan
    faces: FaceThickness | None
    profile: PrinterProfile | None
    materials: MaterialPlan | None
    progress: bool | None
    #: The seconds of what was done before the job (the material plan).
    setup_seconds: Mapping[str, float]
    running: RunSettings

    def run(self, folder: BuildFolder, run: RunFolder | None) -> dict[str, Any]:
        """Compute and write every slab, then the shells and the manifest (no files yet)."""
        mesh, config, plan, stack = self.mesh, self.config, self.plan, folder.stack
        shell_job = ShellJob(
            mesh,
            plan.thickness,
            config,
            estimate_s=plan.estimate.shell_seconds,
            progress=self.progress,
            grid=plan.grid,
        )
        model = self._model(shell_job.shells, shell_job.lattice)
        # Before any other thread (shell process, writers, progress bar) starts: the slab
        # workers are forked.
        setup = stack.enter_context(DeferredSignals())  # no signal until all is registered
        slabs = stack.enter_context(
            SlabRunner(
                model,
                plan.grid,
                plan.rows,
                plan.workers,
                self.materials,
                self._encoder(),
                pages=self._page_encoder(),
                send=self._send(shell_job.writes_meshes),
                scheduler=self.running.scheduler,
                run=run,
            )
        )
        shell_job.start_beside(stack)
        outputs = StackOutputs(
            folder,
            plan.grid,
            config,
            self._profile(),
            self.materials,
            surface=(mesh.vertices, mesh.faces),
        )
        sampler = None  # the voxels compared with the shell meshes, when there are any
        if shell_job.writes_meshes:
            n_slabs = math.ceil(plan.grid.shape_zyx[0] / plan.rows)
            sampler = LayerSampler(plan.grid, model.n_bands, n_slabs=n_slabs)
        tally = Tally(model.n_bands)
        check = self._colour_check()
        setup.close()  # a signal that came during the set-up is raised here
        slabs_s = self._stream(slabs, outputs, sampler, tally, check, shell_job)
        tick = time.perf_counter()
        summaries = outputs.finish()
        finish_s = time.perf_counter() - tick
        shells, shells_seconds = shell_job.wait()
        if self.faces is not None:
            folder.write_thickness(mesh, self.faces)
        agreement, agreement_seconds = None, {}
        if shells is not None and config.shell_meshes:
            shells = folder.write_shells(shells)
            if sampler is not None:
                agreement, agreement_s = self._agreement(model, sampler, shells)
                agreement_seconds = {"agreement": agreement_s}
        self._warn_if_no_core(tally)
        report, report_seconds, proof = None, {}, None
        if check is not None:
            tick = time.perf_counter()
            report = check.result()
            proof = folder.write_proof(check.proof())
            report_seconds = {"colour_report": time.perf_counter() - tick}
        seconds = {
            **self.setup_seconds,
            **shell_job.first_seconds,
            "slabs": slabs_s,
            "writers_finish": finish_s,
            **shells_seconds,
            **agreement_seconds,
            **report_seconds,
        }
        manifest = stack_manifest(
            mesh,
            config,
            plan.grid,
            plan.thickness,
            shells,
            tally,
            seconds,
            shell_agreement=agreement,
            shell_meshes=shell_job.record if shells is not None else None,
            summaries=summaries,
            slab_rows=plan.rows,
            faces=self.faces,
            profile=self._profile(),
            colour_report=report,
            estimate=asdict(plan.estimate),
            run={
                "scheduler": self.running.scheduler,
                "checkpoint": run is not None,
                "resumed_slabs": len(slabs.finished),
                "slabs": len(slabs.ranges),
            },
            tray=self._tray_entry(),
        )
        if proof is not None:
            manifest["proof"] = proof
        return manifest

    def _tray_entry(self) -> dict[str, Any] | None:
        """Return the manifest's ``tray`` section (None: one model, no tray)."""
        return None

    def _profile(self) -> PrinterProfile | None:
        """Return the printer profile when the voxels get materials."""
        return self.profile if self.materials is not None else None

    def _model(self, shells: list[Shell] | None, lattice: NodeLattice | None) -> StackModel:
        """Return what every slab needs.

        The shells only with the "shells" rule; the nodes of the shell meshes with
        distance layers and `field` shells.
        """
        by_distance = self.config.layer_rule == "distance"
        depth = self.plan.depth if by_distance else None
        return stack_model(self.mesh, self.config, depth, shells, lattice)

    def _page_encoder(self) -> PageEncoder | None:
        """Return the slab workers' encoder of TIFF pages, job slices and the store's shards."""
        config, profile = self.config, self._profile()
        slices = None
        if profile is not None and self.materials is not None and "gcvf" in config.formats:
            slices = gcvf_slices(profile, self.materials)
        tiff = "tiff" in config.formats
        shards = zarr_shards(self.plan.grid, config, self.plan.rows, profile)
        if not tiff and slices is None and shards is None:
            return None
        return PageEncoder(
            slices=slices,
            colour_samples=(4 if config.alpha else 3) if tiff else None,
            level=config.compression_level,
            materials_tif=profile is not None,
            zarr=shards,
        )

    def _send(self, sampled: bool) -> tuple[str, ...]:
        """Return the slab arrays this process uses when the workers encode the pages.

        ``layers`` for the voxels compared with the shell meshes (`sampled`); ``layers``
        and ``rgba`` for the PNG slices, the OME-Zarr store and for error diffusion (made
        here); ``layers``, ``rgba`` and ``sdf`` for VDB leaves not encoded where the slab
        is computed.
        """
        config, plan = self.config, self.materials
        send = {"layers"} if sampled else set()
        if "zarr" in config.formats:
            send |= {"layers", "rgba"}
        if plan is not None and ("png" in config.formats or plan.halftone != "blue-noise"):
            send |= {"layers", "rgba"}
        if config.write_vdb and self._encoder() is None:
            send |= {"layers", "rgba", "sdf"}
        return tuple(name for name in SLAB_ARRAYS if name in send)

    def _encoder(self) -> VdbEncoder | None:
        """Return the slab workers' VDB encoder, when slabs hold whole leaf rows."""
        grid, rows = self.plan.grid, self.plan.rows
        whole_leaves = rows % 8 == 0 or rows >= grid.shape_zyx[0]
        halftone_here = self.materials is None or self.materials.halftone == "blue-noise"
        if not (self.config.write_vdb and whole_leaves and halftone_here):
            return None
        return VdbEncoder.for_grid(  # the same grids as StackOutputs' writer
            grid,
            sdf_half_width_mm=self.config.sdf_half_width_mm,
            material_grid=self._profile() is not None,
        )

    def _stream(
        self,
        slabs: SlabRunner,
        outputs: StackOutputs,
        sampler: LayerSampler | None,
        tally: Tally,
        check: ColourCheck | None,
        shell_job: ShellJob,
    ) -> float:
        """Write every slab, in z order, as it comes back from the workers; return the seconds.

        The layer field the slabs kept for the shell meshes is marched meanwhile.
        """
        n_bands = tally.n_layers - 2
        tick = time.perf_counter()
        carry = None
        n_z = self.plan.grid.shape_zyx[0]
        with progress_bar(self.progress, total=n_z, unit="z", desc="voxels") as bar:
            for slab, materials, counts, encoded, pages in slabs:
                if self.materials is not None and materials is None:  # error diffusion, z order
                    diffused = materials_for_slab(
                        slab.layers, slab.rgba, slab.z_start, self.materials, carry=carry
                    )
                    materials, carry = diffused.materials, diffused.carry
                    counts = material_tally(slab.layers, materials, n_bands + 2)
                tally.add(slab, counts)
                if sampler is not None:
                    sampler.add(slab.z_start, slab.layers)
                if check is not None and materials is not None:
                    check.add_slab(slab.z_start, materials)
                shell_job.add_slab(slab)
                outputs.write(slab, materials, encoded, pages, counts)
                bar.update(slab.z_stop - slab.z_start)
        return time.perf_counter() - tick

    def _agreement(
        self, model: StackModel, sampler: LayerSampler, shells: list[Shell]
    ) -> tuple[dict[str, Any], float]:
        """How well the distance layers agree with the shell meshes (sampled voxels); seconds."""
        tick = time.perf_counter()
        points, sampled = sampler.samples()
        agreement = shell_agreement(
            points,
            sampled,
            model.surface,
            self.plan.depth,
            [(s.vertices, s.faces) for s in shells],
            clear_mm=float(np.linalg.norm(self.plan.grid.voxel_mm)),
        )
        return agreement, time.perf_counter() - tick

    def _warn_if_no_core(self, tally: Tally) -> None:
        if tally.counts[-1] == 0 and int(tally.counts[1:].sum()) > 0:
            warn(
                f"{self.mesh.source}: no voxel lies deeper than {float(self.plan.depth.max()):g}"
                f" mm, so the part has no core; use a smaller {opt('thickness')} if that is not "
                "what you want",
            )

    def _colour_check(self) -> ColourCheck | None:
        """Return the colour report's accumulator, with materials and report samples."""
        profile = self._profile()
        if profile is None or self.materials is None or self.config.report_samples == 0:
            return None
        delta_e = 1.0 if self.faces is None else self.faces.rule.colour_layer.delta_e
        return ColourCheck(
            self.mesh, self.config, self.plan, profile, self.materials, delta_e=delta_e
        )
