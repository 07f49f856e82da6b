"""The colour report of a build: predicted printed colour against the model's, at samples.

:class:`ColourCheck` draws the surface samples (:func:`voxel.colour.report.sample_surface`),
accumulates the halftoned material slabs as they are written
(:class:`voxel.colour.report.ColourReport`) and reports CIEDE2000 with what the colour
layer's thickness changes (:func:`voxel.colour.report.thickness_effect`).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.build.plan import BuildPlan
from pipeline.config import BuildConfig
from pipeline.model.mesh import ColouredMesh
from pipeline.model.topology import face_areas
from pipeline.printer.profile import PrinterProfile
from voxel.colour.materials import MaterialPlan
from voxel.colour.report import ColourReport, sample_surface, thickness_effect
from voxel.colour.srgb import codes_to_linear


class ColourCheck:
    """Accumulate a build's material slabs for its colour report.

    Parameters
    ----------
    mesh : ColouredMesh
        The model (the target colours).
    config : BuildConfig
        ``report_samples``, ``optical_depth_mm`` and ``colour_layers``.
    plan : BuildPlan
        The grid and the thickness.
    profile : PrinterProfile
        The materials' display colours.
    materials : MaterialPlan
        The separation behind the halftone.
    """

    def __init__(
        self,
        mesh: ColouredMesh,
        config: BuildConfig,
        plan: BuildPlan,
        profile: PrinterProfile,
        materials: MaterialPlan,
    ) -> None:
        self.mesh, self.config, self.plan = mesh, config, plan
        self.profile, self.materials = profile, materials
        # Drawn in a thread while the first slabs are computed (about 1.4 s on a tray of
        # four models that was serial before them); its errors are raised by add_slab.
        pool = ThreadPoolExecutor(1, thread_name_prefix="colour-check")
        self._report = pool.submit(self._make_report)
        pool.shutdown(wait=False)

    def _make_report(self) -> ColourReport:
        mesh, config = self.mesh, self.config
        samples = sample_surface(
            mesh.vertices, mesh.faces, mesh.colour_at, config.report_samples, seed=0
        )
        display = np.zeros((len(self.profile.materials), 3), dtype=np.uint8)
        for material in self.profile.materials:
            display[material.index] = material.display_srgb
        return ColourReport(
            samples, self.plan.grid, display, optical_depth_mm=config.optical_depth_mm
        )

    @property
    def report(self) -> ColourReport:
        """The accumulator (waits for it to be made)."""
        return self._report.result()

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Take the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``."""
        self.report.add_slab(z_start, materials)

    def result(self) -> dict[str, Any]:
        """Return the measured report and what the thickness changes (optical model)."""
        result = self.report.result()
        samples = self.report.samples
        display = np.array([m.display_srgb for m in self.profile.materials], dtype=np.uint8)
        linear = codes_to_linear(display).astype(np.float64)
        share = self.materials.separation.proportions(samples.target_rgba).astype(np.float64)
        ideal = share @ linear[list(self.materials.column_materials)]
        colour_depth = self.plan.depth[max(self.config.colour_layers) - 1]
        area = face_areas(self.mesh.vertices, self.mesh.faces)
        result["thickness_effect"] = thickness_effect(
            samples.target_rgba,
            ideal,
            linear[self.materials.backing_material],
            colour_depth[samples.face_ids],
            _weighted_mean(colour_depth, area),
            self.config.optical_depth_mm,
        )
        return result


def _weighted_mean(values: NDArray[np.float64], weights: NDArray[np.float64]) -> float:
    """Return the weighted mean with correctly rounded sums (``math.fsum``).

    numpy's vectorised sums may round differently with the arrays' memory alignment;
    equal builds must write equal reports.
    """
    return math.fsum((values * weights).tolist()) / math.fsum(weights.tolist())
