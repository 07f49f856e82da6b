"""A tray's plan, fixed before any work: models, layout, grids, the tray grid and the cost.

:func:`plan_tray` reads each distinct model file once, scales and turns each model, finds
its layer count and an upper bound of its deepest layer without computing any thickness
rule (a rule's colour layers are at most its clamp, its backing layers constant), lays
the models out (:mod:`shellvox.tray._layout`), gives each model its own grid (the grid a
build of it alone has, :func:`shellvox.stack._plan.grid_for`) and snaps each to the
printer's voxel lattice of the tray, so that every model grid sits in the tray grid at a
whole voxel offset. The estimate covers the tray grid and every model's band; a tray that
cannot fit is refused here (:func:`shellvox.stack._estimate.check_resources`). ``--dry-run``
stops here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.config import BuildConfig, LoadOptions
from shellvox.errors import ResourceError, opt
from shellvox.loading import load_model
from shellvox.model import ColouredMesh
from shellvox.output import sha256
from shellvox.run import resolve_workers
from shellvox.stack import (
    BuildEstimate,
    check_resources,
    estimate_build,
    report_sample_count,
    slab_rows_for,
    store_buffer_rows,
)
from shellvox.thickness import DEFAULT_RULE, ThicknessRule
from shellvox.tray._layout import Layout, LayoutMode, lay_out
from shellvox.tray._parts import ThicknessSource, TrayPart, check_same_layers, extent, prepare_part
from shellvox.tray._spec import TraySpec
from shellvox.voxel.grid import GridSpec


@dataclass(frozen=True)
class Placement:
    """One model on the tray.

    Attributes
    ----------
    part : int
        Index of its :class:`TrayPart`.
    copy : int
        Copy number, from 1.
    name : str
        Its name in messages and the manifest.
    requested_mm : (3,) float, mm
        Where its bounding-box minimum was asked (or packed) to go.
    actual_mm : (3,) float, mm
        Where it goes: snapped so its grid sits at a whole voxel offset.
    shift_mm : (3,) float, mm
        The move from its own coordinates to the tray's.
    offset_zyx : (3,) int
        Index of its grid's voxel ``(0, 0, 0)`` in the tray grid.
    """

    part: int
    copy: int
    name: str
    requested_mm: tuple[float, float, float]
    actual_mm: tuple[float, float, float]
    shift_mm: tuple[float, float, float]
    offset_zyx: tuple[int, int, int]


@dataclass(frozen=True, eq=False)
class TrayPlan:
    """Everything fixed before a tray is built (see the module).

    Attributes
    ----------
    spec : TraySpec
    parts : tuple of TrayPart
    placements : tuple of Placement
    layout : Layout
    min_gap_mm : float, mm
        The least gap between two models the voxels need.
    tray_mm : (3,) float, mm
        The printer's tray.
    grid : GridSpec
        The tray grid.
    rows, workers : int
        Slab height and slab processes.
    estimate : BuildEstimate
    """

    spec: TraySpec
    parts: tuple[TrayPart, ...]
    placements: tuple[Placement, ...]
    layout: Layout
    min_gap_mm: float
    tray_mm: tuple[float, float, float]
    grid: GridSpec
    rows: int
    workers: int
    estimate: BuildEstimate

    def lines(self) -> list[str]:
        """Return the layout for the user, one line per model."""
        lines = [
            f"tray of {len(self.placements)} model(s), layout {self.layout.mode}, gap "
            f"{self.layout.gap_mm:.3g} mm (at least {self.min_gap_mm:.3g} mm), printer tray "
            + " x ".join(f"{t:g}" for t in self.tray_mm)
            + " mm:"
        ]
        for place in self.placements:
            part = self.parts[place.part]
            low = np.asarray(place.actual_mm)
            high = low + extent(part.mesh)
            lines.append(
                f"  {place.name}: x {low[0]:.2f}..{high[0]:.2f}, y {low[1]:.2f}..{high[1]:.2f},"
                f" z {low[2]:.2f}..{high[2]:.2f} mm; {part.thickness.describe()}"
            )
        return lines

    def manifest(self, face_starts: NDArray[np.int64]) -> dict[str, Any]:
        """Return the manifest's ``tray`` section (`face_starts`: ``(N + 1,)`` of the tray mesh)."""
        models = []
        for index, place in enumerate(self.placements):
            part = self.parts[place.part]
            low = np.asarray(place.actual_mm)
            models.append(
                {
                    "name": place.name,
                    "file": str(part.spec.file),
                    "sha256": sha256(part.spec.file) if part.spec.file.is_file() else None,
                    "copy": place.copy,
                    "rotation_deg": list(part.spec.rotation_deg),
                    "rotation_convention": "extrinsic x, y, z (degrees), before placement",
                    "scale": part.spec.scale,
                    "size_mm": part.spec.size_mm,
                    "loaded": part.mesh.loaded,
                    "requested_position_mm": list(place.requested_mm),
                    "position_mm": list(place.actual_mm),
                    "bounds_mm": [list(low), list(low + extent(part.mesh))],
                    "shift_mm": list(place.shift_mm),
                    "grid_offset_zyx": list(place.offset_zyx),
                    "grid_shape_zyx": list(part.grid.shape_zyx),
                    "faces": [int(face_starts[index]), int(face_starts[index + 1])],
                    "thickness": part.thickness.describe(),
                }
            )
        return {
            "source": self.spec.source,
            "layout": self.layout.mode,
            "gap_mm": self.layout.gap_mm,
            "min_gap_mm": self.min_gap_mm,
            "tray_mm": list(self.tray_mm),
            "models": models,
        }


def plan_tray(
    spec: TraySpec,
    options: LoadOptions,
    config: BuildConfig,
    out_dir: Path,
    *,
    tray_mm: tuple[float, float, float],
    mode: LayoutMode,
    gap_mm: float,
    default_thickness: ThicknessSource,
    colour_layers: tuple[int, ...] | None = None,
    force: bool = False,
) -> TrayPlan:
    """Return the plan of a tray, or refuse it (see the module).

    Parameters
    ----------
    spec : TraySpec
        The models.
    options : LoadOptions
        How the files are read (``--scale`` multiplies each model's own scale).
    config : BuildConfig
        Voxel size, margin, level set, slab size and workers.
    out_dir : Path
        Output folder (its file system must hold the estimated files).
    tray_mm : (3,) float, mm
        The printer's tray.
    mode : {"auto", "given", "keep"}
        Layout (:func:`shellvox.tray._layout.lay_out`).
    gap_mm : float, mm
        Gap between packed models.
    default_thickness : ThicknessSource
        The command line's thickness, for models whose entry gives none.
    colour_layers : tuple of int, optional
        ``--colour-layers`` (default: each rule's, 1 for a constant thickness).
    force : bool
        Plan even when the estimate says memory or disk will not suffice.

    Raises
    ------
    InputError
        A model cannot be read, the models' layer counts or colour layers differ, or the
        layout does not fit.
    ResourceError
        The tray cannot fit this machine.
    """
    loaded: dict[Path, ColouredMesh] = {}
    rules: dict[Path | None, ThicknessRule] = {None: DEFAULT_RULE}
    parts = []
    for model in spec.models:
        key = model.file.resolve()
        if key not in loaded:
            # a model the tray scales itself is not judged by its size as loaded
            sized = any(
                m.size_mm is not None or m.scale != 1.0
                for m in spec.models
                if m.file.resolve() == key
            )
            loaded[key] = load_model(model.file, options, size_warning=not sized)
        parts.append(
            prepare_part(model, loaded[key], rules, config, default_thickness, colour_layers)
        )
    check_same_layers(parts, spec.source or "the command line's models")
    names, part_of, copies = _names(parts)
    extents = np.array([extent(parts[i].mesh) for i in part_of])
    requested: list[tuple[float, float, float] | None] = [
        _triple(parts[i].mesh.vertices.min(axis=0)) if mode == "keep" else parts[i].spec.position_mm
        for i in part_of
    ]
    reach = max(p.reach_mm for p in parts)
    voxel = np.asarray(config.voxel_mm, dtype=np.float64)
    # Tiles must not overlap: each grid reaches its margin plus two voxels beyond its
    # box, and snapping moves a model by up to half a voxel.
    pad = max(max(config.margin_mm, config.sdf_half_width_mm), float(voxel.max()))
    min_gap = max(reach + config.sdf_half_width_mm, 2 * pad + 5 * float(voxel.max()))
    layout = lay_out(
        names,
        extents,
        requested,
        mode=mode,
        tray_mm=tray_mm,
        gap_mm=gap_mm,
        min_gap_mm=min_gap,
        source=opt("tray", str(spec.source)) if spec.source else opt("layout"),
    )
    placements, grid = _snap(parts, part_of, copies, names, layout.positions_mm, voxel)
    workers = resolve_workers(config.workers)
    rows = slab_rows_for(grid, config.slab_mb)
    estimate = estimate_build(
        grid.shape_zyx,
        grid.voxel_mm,
        bands=[(parts[i].area_mm2, parts[i].reach_mm) for i in part_of],
        n_faces=sum(p.mesh.n_faces for p in parts),
        slab_rows=rows,
        workers=min(workers, -(-grid.shape_zyx[0] // rows)),
        store_rows=store_buffer_rows(config.formats, rows),
        report_samples=(
            report_sample_count(
                sum(parts[i].area_mm2 for i in part_of),
                config.report_samples,
                config.proof_density,
            )
            if config.material is not None
            else 0
        ),
    )
    try:
        check_resources(estimate, out_dir, force=force)
    except ResourceError as error:  # the whole estimate, as --dry-run would print it
        path, problem, fix = error.parts
        raise ResourceError(path, f"{problem} (estimate: {estimate.line()})", fix) from None
    return TrayPlan(
        spec, tuple(parts), placements, layout, min_gap, tray_mm, grid, rows, workers, estimate
    )


def _names(parts: list[TrayPart]) -> tuple[list[str], list[int], list[int]]:
    """Return each model's name (``file#n`` where a name repeats), part and copy number."""
    part_of = [i for i, p in enumerate(parts) for _ in range(p.spec.copies)]
    copies = [c + 1 for p in parts for c in range(p.spec.copies)]
    bare = [parts[i].spec.name for i in part_of]
    seen: dict[str, int] = {}
    names = []
    for name in bare:
        seen[name] = seen.get(name, 0) + 1
        names.append(name if bare.count(name) == 1 else f"{name}#{seen[name]}")
    return names, part_of, copies


def _snap(
    parts: list[TrayPart],
    part_of: list[int],
    copies: list[int],
    names: list[str],
    positions: NDArray[np.float64],
    voxel: NDArray[np.float64],
) -> tuple[tuple[Placement, ...], GridSpec]:
    """Snap each model grid to the tray's voxel lattice; return placements and the tray grid.

    Tray voxel ``i`` (x, y, z) of the lattice is centred at ``i * voxel``: a model grid
    whose origin lands on it sits at a whole voxel offset in the tray grid.
    """
    starts = []
    shifts = []
    for i, position in zip(part_of, positions, strict=True):
        part = parts[i]
        wanted = np.asarray(part.grid.origin_mm) + position - part.mesh.vertices.min(axis=0)
        start = np.round(wanted / voxel).astype(np.int64)
        starts.append(start)
        shifts.append(start * voxel - np.asarray(part.grid.origin_mm))
    lower = np.min(starts, axis=0)
    upper = np.max(
        [
            s + np.asarray(parts[i].grid.shape_zyx[::-1])
            for s, i in zip(starts, part_of, strict=True)
        ],
        axis=0,
    )
    size = upper - lower
    grid = GridSpec(
        tuple(float(v) for v in lower * voxel),  # type: ignore[arg-type]
        tuple(float(v) for v in voxel),  # type: ignore[arg-type]
        (int(size[2]), int(size[1]), int(size[0])),
    )
    placements = []
    for i, copy, name, position, start, shift in zip(
        part_of, copies, names, positions, starts, shifts, strict=True
    ):
        offset = start - lower
        actual = parts[i].mesh.vertices.min(axis=0) + shift
        placements.append(
            Placement(
                part=i,
                copy=copy,
                name=name,
                requested_mm=_triple(position),
                actual_mm=_triple(actual),
                shift_mm=_triple(shift),
                offset_zyx=(int(offset[2]), int(offset[1]), int(offset[0])),
            )
        )
    return tuple(placements), grid


def _triple(values: NDArray[np.float64]) -> tuple[float, float, float]:
    return (float(values[0]), float(values[1]), float(values[2]))
