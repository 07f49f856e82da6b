"""The colour report of a build: the printed colour predicted from its voxels, at samples.

:class:`ColourCheck` draws the surface samples
(:func:`shellvox.voxel.colour._report.sample_surface`), reads the halftoned material slabs under
them as they are written (:class:`shellvox.voxel.colour._model_report.ModelReport`: the two-flux
model of the printer's optics over each voxel column) and reports CIEDE2000 with the errors apart:

- ``gamut``: the target against the colour the separation aims at (its mix infinitely
  deep), what no printing can reach;
- ``reproduction``: that aim against the prediction from the voxels (halftone, voxels,
  depth);
- ``in_gamut``: the target against the prediction, for targets within 1 of the gamut
  whose colour is the same all around them, as far as their light spreads and
  :data:`UNIFORM_MARGIN_MM` beyond (the colour regions' interiors, what a measured
  patch is); ``in_gamut_all`` with the samples near a colour edge too, whose columns see
  the neighbouring colour (light spreads sideways, so no print keeps an edge sharper
  than that: a resolution limit, given apart);
  ``ciede2000`` for all samples.

and what the colour layer's per-face depth buys against one constant depth
(:func:`shellvox.voxel.colour._depth_effect.depth_effect`). Everything is under the profile's
optics, assumed or measured, as the report says.

The same samples are the build's soft proof (:meth:`ColourCheck.proof`,
:class:`shellvox.voxel.colour.SoftProof`): their count is the larger of
``report_samples`` and ``proof_density`` times the surface's area (at most
:data:`~shellvox.voxel.colour.PROOF_MAX_SAMPLES`), so that a 1 mm colour patch holds
about 12 of them at the default density.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any, NamedTuple

import colour
import numpy as np
from numpy.typing import NDArray

from shellvox.config import BuildConfig
from shellvox.model import ColouredMesh, face_areas
from shellvox.printer import PrinterProfile, layer_model
from shellvox.stack._estimate import REPORT_GATHER_BYTES, report_sample_count
from shellvox.stack._plan import BuildPlan
from shellvox.voxel.colour import (
    IN_GAMUT_DE,
    LayerModel,
    MaterialPlan,
    ModelReport,
    SoftProof,
    SurfaceSamples,
    colour_regions,
    depth_effect,
    lateral_reach,
    observer,
    sample_surface,
    srgb8_to_lab,
    srgb_to_lab_d50,
    statistics,
    summary,
    tangent_basis,
)
from shellvox.voxel.geometry import SurfaceIndex, nearest_on_surface

#: Material voxels gathered before the report counts them (bytes, one per voxel).
GATHER_BYTES = REPORT_GATHER_BYTES

#: A sample lies inside a colour region when the mean CIELAB of the surface colour at
#: :data:`RING_POINTS` points around it, its lateral reach (the report's disc) and this
#: margin away, is its own colour within :data:`UNIFORM_DE` CIEDE2000 (a smooth gradient
#: averages to its centre) and no point is farther than :data:`EDGE_DE` from it (a sample
#: on an edge, whose own colour is the blend of the two sides, averages to itself too).
UNIFORM_MARGIN_MM = 0.1
RING_POINTS = 12
UNIFORM_DE = 1.0
EDGE_DE = 5.0


class _Columns(NamedTuple):
    samples: SurfaceSamples
    report: ModelReport
    model: LayerModel
    shares: NDArray[np.float64]
    reach: NDArray[np.float64]
    surface: SurfaceIndex


class ColourCheck:
    """Accumulate a build's material slabs for its colour report.

    Parameters
    ----------
    mesh : ColouredMesh
        The model (the target colours).
    config : BuildConfig
        ``report_samples`` and ``colour_layers``.
    plan : BuildPlan
        The grid and the thickness.
    profile : PrinterProfile
        The materials' optics.
    materials : MaterialPlan
        The separation behind the halftone.
    delta_e : float
        CIEDE2000 within which a colour counts as settled (the rule's).
    """

    def __init__(
        self,
        mesh: ColouredMesh,
        config: BuildConfig,
        plan: BuildPlan,
        profile: PrinterProfile,
        materials: MaterialPlan,
        *,
        delta_e: float = 1.0,
    ) -> None:
        self.mesh, self.config, self.plan = mesh, config, plan
        self.profile, self.materials, self.delta_e = profile, materials, delta_e
        self._gathered: list[NDArray[np.uint8]] = []
        self._gathered_start = self._gathered_end = 0
        self._proof: SoftProof | None = None
        # Made in a thread while the first slabs are computed; its errors are raised by
        # add_slab.
        pool = ThreadPoolExecutor(1, thread_name_prefix="colour-check")
        self._report = pool.submit(self._make_report)
        pool.shutdown(wait=False)

    def _make_report(self) -> _Columns:
        mesh, config = self.mesh, self.config
        area = float(face_areas(mesh.vertices, mesh.faces).sum())
        count = report_sample_count(area, config.report_samples, config.proof_density)
        samples = sample_surface(mesh.vertices, mesh.faces, mesh.colour_at, count, seed=0)
        backing = [
            float(np.median(row))
            for k, row in enumerate(self.plan.thickness)
            if k + 1 not in self.config.colour_layers
        ]
        model = layer_model(self.profile, self.materials, backing)
        shares = model.shares(samples.target_rgba)
        reach = lateral_reach(*model.absorption_scattering(shares))
        grid, optics = self.plan.grid, self.profile.optics
        surface = SurfaceIndex.build(mesh.vertices, mesh.faces)
        report = ModelReport(
            samples.points, samples.normals, grid, optics, disc_radius_mm=reach, surface=surface
        )
        return _Columns(samples, report, model, shares, reach, surface)

    @property
    def samples(self) -> SurfaceSamples:
        """The surface samples (waits for them)."""
        return self._report.result().samples

    @property
    def report(self) -> ModelReport:
        """The accumulator (waits for it to be made)."""
        return self._report.result().report

    def add_slab(self, z_start: int, materials: NDArray[np.uint8]) -> None:
        """Take the material indices ``(Zs, Y, X) uint8`` of rows ``z_start..``.

        Consecutive slabs are gathered up to :data:`GATHER_BYTES` and counted together:
        every disc whose rays reach a block walks them once per block, so thin slabs
        (a few rows) would multiply that work; the counts do not depend on the blocks.
        """
        if self._gathered and self._gathered_end != z_start:
            self._count_gathered()
        if not self._gathered:
            self._gathered_start = z_start
        self._gathered.append(np.array(materials, dtype=np.uint8))
        self._gathered_end = z_start + len(materials)
        if sum(block.nbytes for block in self._gathered) >= GATHER_BYTES:
            self._count_gathered()

    def _count_gathered(self) -> None:
        if self._gathered:
            block = np.concatenate(self._gathered)
            self._gathered = []
            self.report.add_slab(self._gathered_start, block)

    def result(self) -> dict[str, Any]:
        """Return the report: errors apart, per region, and what per-face depth buys."""
        self._count_gathered()
        samples, report, model, shares, reach, surface = self._report.result()
        aim = model.deep_lab(shares)
        white = observer(self.profile.optics.wavelengths_nm).white_xy
        target = srgb_to_lab_d50(samples.target_rgba[:, :3] / 255.0, white)
        errors = report.errors(aim, target)
        area = float(face_areas(self.mesh.vertices, self.mesh.faces).sum())
        self._proof = SoftProof(
            points_mm=samples.points,
            normals=samples.normals,
            target_lab=target,
            aim_lab=aim,
            predicted_lab=errors.predicted_lab,
            total_de=errors.total,
            gamut_de=errors.gamut,
            reproduction_de=errors.reproduction,
            spacing_mm=float(np.sqrt(area / max(len(samples.points), 1))),
            white_xy=np.asarray(white, np.float64),
            optics="assumed" if self.profile.optics.assumed else "measured",
        )
        interior = uniform_surroundings(
            self.mesh, samples, reach + UNIFORM_MARGIN_MM, surface=surface
        )
        result = summary(errors, interior, in_gamut_de=IN_GAMUT_DE)
        result["lateral_reach_mm"] = statistics(reach)
        regions = colour_regions(samples.target_rgba[:, :3])
        seen, total, gamut = errors.seen, errors.total, errors.gamut
        per_region = {}
        for name in sorted(set(regions[seen].tolist())):
            chosen = seen & (regions == name)
            inside = chosen & (gamut <= IN_GAMUT_DE) & interior
            per_region[name] = {
                "samples": int(chosen.sum()),
                "gamut": statistics(gamut[chosen]),
                "in_gamut_samples": int(inside.sum()),
                "in_gamut": statistics(total[inside]),
            }
        result["per_region"] = per_region
        colour_depth = self.plan.depth[max(self.config.colour_layers) - 1][samples.face_ids]
        result["depth_effect"] = depth_effect(
            model, shares, colour_depth, delta_e=self.delta_e, max_mm=3.0
        )
        result["optics"] = "assumed" if self.profile.optics.assumed else "measured"
        return result

    def proof(self) -> SoftProof:
        """Return the soft proof at the samples (after :meth:`result`)."""
        if self._proof is None:
            raise RuntimeError("ColourCheck.proof() is known once result() has run")
        return self._proof


def uniform_surroundings(
    mesh: ColouredMesh,
    samples: SurfaceSamples,
    radius_mm: NDArray[np.float64],
    *,
    surface: SurfaceIndex | None = None,
) -> NDArray[np.bool_]:
    """Return which samples lie inside a colour region, not at an edge (see the module).

    The mean CIELAB of the surface colour at :data:`RING_POINTS` points `radius_mm`
    ``(N,)`` around each sample in its tangent plane (at the nearest surface points)
    against its own colour, and the farthest of them. `surface` is the mesh's index when
    the caller has one.
    """
    if len(samples.points) == 0:
        return np.zeros(0, bool)
    if surface is None:
        surface = SurfaceIndex.build(mesh.vertices, mesh.faces)
    angle = 2 * np.pi * np.arange(RING_POINTS) / RING_POINTS
    u, v = tangent_basis(samples.normals)
    ring = samples.points[:, None] + np.asarray(radius_mm, np.float64)[:, None, None] * (
        np.cos(angle)[None, :, None] * u[:, None] + np.sin(angle)[None, :, None] * v[:, None]
    )
    hit = nearest_on_surface(surface, ring.reshape(-1, 3))
    around = mesh.colour_at(hit.face_ids, hit.barycentric).reshape(len(ring), RING_POINTS, 4)
    own = srgb8_to_lab(samples.target_rgba[:, :3])
    theirs = srgb8_to_lab(around[..., :3])
    mean = colour.delta_E(theirs.mean(axis=1), own, method="CIE 2000")
    each = colour.delta_E(theirs, own[:, None], method="CIE 2000").max(axis=1)
    return np.asarray((mean <= UNIFORM_DE) & (each <= EDGE_DE), bool)


def report_line(report: dict[str, Any] | None) -> str | None:
    """Return the colour report's line for the user (None without a report).

    The errors apart: the prediction against in-gamut targets inside colour regions and
    near colour edges, the reproduction (the prediction against the separation's aim,
    measurable where no target is in gamut) and the gamut error.
    """
    if not report or report["ciede2000"]["median"] is None:
        return None
    inside, gamut = report["in_gamut"], report["gamut"]
    edges = report["near_colour_edges"]
    edge = edges["in_gamut"]["median"]
    aim = report["reproduction_inside_colour_regions"]
    return (
        f"predicted colour vs target, CIEDE2000 ({report['optics']} optics, "
        f"{report['samples_seen']:,} surface samples): in gamut, inside colour regions "
        f"({report['in_gamut_samples']:,}) {_median_p95(inside)}; near colour edges "
        f"({edges['samples']:,}) median {'-' if edge is None else format(edge, '.2f')}; "
        f"vs the separation's aim inside colour regions {_median_p95(aim)}; "
        f"gamut error median {gamut['median']:.2f}, p95 {gamut['p95']:.2f}"
    )


def _median_p95(statistics: dict[str, Any]) -> str:
    if statistics["median"] is None:
        return "none"
    return f"median {statistics['median']:.2f}, p95 {statistics['p95']:.2f}"
