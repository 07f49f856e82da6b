"""What ``manifest.json`` says about a build: input, grid, layers, counts, materials, timings.

:class:`Tally` counts the voxels of the slabs as they come (per layer, per layer and
material, and the slabs' diagnostics); :func:`stack_manifest` assembles the whole manifest
from the build's results, which :meth:`shellvox.output._folder.BuildFolder.commit` completes
with the files (and the total time) and writes.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox import __version__
from shellvox.config import BuildConfig, as_json
from shellvox.model import ColouredMesh
from shellvox.offset.shells import Shell
from shellvox.output._outdir import sha256
from shellvox.printer import PrinterProfile
from shellvox.thickness import FaceThickness, thickness_summary
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import SlabResult


class Tally:
    """Voxels per layer, per layer and material, and the slabs' diagnostics.

    Parameters
    ----------
    n_bands : int
        Shell bands ``K`` (layers 0 outside .. ``K + 1`` core).
    """

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
        """Return every material used (and void) with its voxel count."""
        totals = self.by_material.sum(axis=0)
        return [
            {
                "index": m.index,
                "name": m.name,
                "job_name": m.job_name,
                "role": m.role,
                "rgba_key": list(m.rgba_key),
                "display_srgb": list(m.display_srgb),
                "voxels": int(totals[m.index]),
            }
            for m in profile.materials
            if totals[m.index] > 0 or m.index == 0
        ]

    def per_layer(self, profile: PrinterProfile) -> dict[str, dict[str, int]]:
        """Return ``{layer: {material name: voxels}}``."""
        return {
            str(layer): {
                profile.materials[index].name: int(count)
                for index, count in enumerate(row)
                if count and index < len(profile.materials)
            }
            for layer, row in enumerate(self.by_material)
        }


def stack_manifest(
    mesh: ColouredMesh,
    config: BuildConfig,
    grid: GridSpec,
    thickness: NDArray[np.float64],
    shells: list[Shell] | None,
    tally: Tally,
    seconds: Mapping[str, float],
    *,
    shell_agreement: dict[str, Any] | None,
    shell_meshes: Mapping[str, Any] | None = None,
    summaries: Mapping[str, Any],
    slab_rows: int,
    faces: FaceThickness | None,
    profile: PrinterProfile | None,
    colour_report: dict[str, Any] | None,
    estimate: Mapping[str, Any],
    run: Mapping[str, Any],
    tray: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Return the whole manifest of a stack, but for ``files`` (:meth:`BuildFolder.commit`).

    Parameters
    ----------
    mesh : ColouredMesh
        The model (its source file is hashed).
    config : BuildConfig
        The build's configuration.
    grid : GridSpec
        The voxel grid.
    thickness : (K, F) float64, mm
        Thickness of each layer per face.
    shells : list of Shell or None
        The shells as written (their face counts are reported).
    tally : Tally
        The voxel counts (and, with `profile`, the materials).
    seconds : mapping
        The stages' timings (copied; ``total`` is added when the manifest is written).
    shell_agreement : dict or None
        How well the distance layers agree with the shell meshes.
    shell_meshes : mapping or None
        How the shell meshes were made (the method's record: for ``field``, its nodes,
        where their layer field came from and how many scans it took).
    summaries : mapping
        The writers' summaries (``tiff``, ``vdb``, ``gcvf``, ...), in the manifest's order.
    slab_rows : int
        Rows of a slab.
    faces : FaceThickness or None
        The thickness rule's result (``thickness``).
    profile : PrinterProfile or None
        The printer, when the voxels have materials (``printer``, ``optics``,
        ``materials``, ``material_voxels_per_layer``).
    colour_report : dict or None
        The colour report, when there is one.
    estimate : mapping
        The cost estimate, as a dict.
    run : mapping
        How the slabs ran (scheduler, checkpoints, slabs resumed).
    tray : dict or None
        A tray's section (its models and their places).
    """
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
    manifest: dict[str, Any] = {
        "tool": f"shellvox {__version__}",
        "input": {
            "path": mesh.source,
            "sha256": _sha256(mesh.source),
            "faces": mesh.n_faces,
            "loaded": dict(mesh.loaded),
        },
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
        "seconds": dict(seconds),
        "shell_agreement": shell_agreement,
        **({"shell_meshes": dict(shell_meshes)} if shell_meshes is not None else {}),
        **summaries,
        "slab_rows": slab_rows,
        "thickness": thickness_entry(config, faces),
    }
    if profile is not None:
        manifest["printer"] = profile.name
        manifest["optics"] = profile.optics.manifest()
        manifest["materials"] = tally.materials(profile)
        manifest["material_voxels_per_layer"] = tally.per_layer(profile)
    if colour_report is not None:
        manifest["colour_report"] = colour_report
    manifest["estimate"] = dict(estimate)
    manifest["run"] = dict(run)
    if tray is not None:
        manifest["tray"] = tray
    return manifest


def thickness_entry(config: BuildConfig, faces: FaceThickness | None) -> dict[str, Any]:
    """Return the manifest's ``thickness``: its source and the rule's per-face summary."""
    if faces is None:
        return {"source": config.thickness_source}
    return {"source": config.thickness_source, **thickness_summary(faces)}


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
