"""``build_tray``: several models, one stack, one job.

Each model of a :class:`shellvox.tray._plan.TrayPlan` keeps its own mesh, colour source,
thickness and grid; the slabs are composed from the models' tiles
(:mod:`shellvox.voxel.tray_slab`), so everything after the slabs (materials and halftone in tray
coordinates, the writers, the job, the colour report) is the single-model build's
(:mod:`shellvox.stack._stack`). The tray's mesh (:class:`shellvox.tray._mesh.TrayMesh`) stands for
the models in the manifest, ``thickness.ply`` (when every model has a thickness rule)
and the colour report; the manifest gets a ``tray`` section.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from shellvox.config import BuildConfig
from shellvox.errors import InputError, opt
from shellvox.model import ColouredMesh
from shellvox.offset.shells import Shell
from shellvox.printer import PrinterProfile
from shellvox.run import RunSettings, model_key, run_key
from shellvox.stack import BuildPlan, check_depth, run_job, settle_running
from shellvox.stack._stack import _Job, _material_plan, stack_model
from shellvox.thickness import FaceThickness
from shellvox.tray._mesh import TrayMesh, concatenate_thickness
from shellvox.tray._plan import TrayPlan
from shellvox.voxel.geometry import NodeLattice
from shellvox.voxel.slab import StackModel
from shellvox.voxel.tray_slab import TrayStack


def build_tray(
    plan: TrayPlan,
    config: BuildConfig,
    out_dir: Path,
    *,
    meshes: Sequence[ColouredMesh],
    thickness: Sequence[NDArray[np.float64]],
    faces: Sequence[FaceThickness | None],
    profile: PrinterProfile | None = None,
    progress: bool | None = None,
    force: bool = False,
    say: Callable[[str], None] | None = None,
    running: RunSettings | None = None,
) -> dict[str, Any]:
    """Build the layered voxel stack of a tray into ``out_dir``.

    Parameters
    ----------
    plan : TrayPlan
        The models, their places, the tray grid and the estimate.
    config : BuildConfig
        Grid, layers and output options; the distance layer rule, no shell meshes.
        Its ``thickness_mm`` and ``thickness_source`` are set here.
    out_dir : Path
        Output folder, as :func:`shellvox.stack._stack.build_stack`.
    meshes : sequence of ColouredMesh
        Each part of the plan (:attr:`TrayPlan.parts`) as its thickness applies to it
        (split by ``--max-edge``, or the part's own mesh).
    thickness : sequence of (K, F_i) float64, mm
        Each part's layer thickness per face.
    faces : sequence of FaceThickness or None
        Each part's rule result (None: a constant thickness).
    profile, progress, force, say, running
        As :func:`shellvox.stack._stack.build_stack`.

    Returns
    -------
    dict
        The manifest, with its ``tray`` section, as written to ``out_dir/manifest.json``.
    """
    started = time.perf_counter()
    if config.layer_rule != "distance" or config.shell_meshes:
        raise InputError(
            f"{opt('layer_rule', 'shells')} / {opt('shell_meshes')}",
            "a tray is built with distance layers and without shell meshes",
            f"drop {opt('layer_rule', 'shells')} and {opt('shell_meshes')}; make each model's "
            "shells on its own",
        )
    if say is not None:
        say(plan.estimate.line())
    models = []
    for part, mesh, rows in zip(plan.parts, meshes, thickness, strict=True):
        depth = np.cumsum(rows, axis=0)
        check_depth(mesh, depth, force=force, source=part.thickness.describe())
        models.append(stack_model(mesh, config, depth))
    places = plan.placements
    tray = TrayStack(
        tuple(models[p.part] for p in places),
        tuple(plan.parts[p.part].grid for p in places),
        tuple(p.offset_zyx for p in places),
    )
    mesh = TrayMesh.place(
        [meshes[p.part] for p in places],
        np.array([p.shift_mm for p in places]),
        plan.spec.source or " + ".join(p.name for p in places),
    )
    rows = np.concatenate([thickness[p.part] for p in places], axis=1)
    given = [f for f in (faces[p.part] for p in places) if f is not None]
    face_thickness = concatenate_thickness(given) if len(given) == len(places) else None
    config = dataclasses.replace(
        config,
        thickness_mm=tuple(float(np.median(row)) for row in rows),
        thickness_source="tray: each model's own (see tray.models)",
    )
    build_plan = BuildPlan(
        plan.grid, rows, np.cumsum(rows, axis=0), plan.rows, plan.workers, plan.estimate
    )
    materials, seconds = _material_plan(profile, config, int(rows.shape[0]))
    running = settle_running(running, build_plan)
    entry = plan.manifest(mesh.face_starts)
    parts = json.dumps([[model_key(meshes[p.part]), p.offset_zyx] for p in places])
    key = run_key(
        mesh,
        config,
        plan.grid,
        plan.rows,
        rows,
        (profile, materials, entry["models"]),
        model=hashlib.sha256(parts.encode()).hexdigest(),
    )
    job = _TrayJob(
        mesh,
        config,
        build_plan,
        face_thickness,
        profile,
        materials,
        progress,
        seconds,
        running,
        tray=tray,
        entry=entry,
    )
    return run_job(job, Path(out_dir), key, started)


@dataclass(frozen=True, eq=False)
class _TrayJob(_Job):
    """A build run whose slabs are composed from the models' tiles."""

    tray: TrayStack | None = None
    entry: dict[str, Any] | None = None

    def _tray_entry(self) -> dict[str, Any] | None:
        """Return the manifest's ``tray`` section: the models and their places."""
        return self.entry

    def _model(self, shells: list[Shell] | None, lattice: NodeLattice | None) -> StackModel:
        """Return the tray: the slab runner hands it to compute_slab, which takes trays.

        A tray has distance layers and no shell meshes: no shells, no lattice.
        """
        assert self.tray is not None
        return cast(StackModel, self.tray)
