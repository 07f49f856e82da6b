"""The frozen configuration of ``shellvox build``; it serialises into ``manifest.json``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from pipeline.material_plan import MaterialSettings

#: Output formats ``build`` can write (``--format``).
FORMATS = ("tiff", "vdb", "gcvf", "png")


@dataclass(frozen=True)
class BuildConfig:
    """How a layered voxel stack is built.

    Parameters
    ----------
    voxel_mm : (3,) float, mm
        Voxel size ``(x, y, z)``.
    printer : str or None
        Printer profile the voxel size came from (``"j750"``), for the manifest.
    thickness_mm : tuple of float, mm
        Thickness of each shell band, outside in (``K`` values).
    thickness_source : str
        Where the thickness came from: ``"--thickness"`` (``thickness_mm`` on every face),
        ``"default rule"`` or a rule file (per face; ``thickness_mm`` then holds each
        layer's median, and the per-face values are in ``thickness.ply``).
    colour_layers : tuple of int
        Layers (1..K+1) whose voxels take the nearest surface colour.
    layer_rule : {"distance", "shells"}
        How voxels get their layer: ``"distance"`` compares each voxel's exact distance
        to the surface with the depths of its nearest face (the ideal offset, sampled
        exactly); ``"shells"`` counts the offset shells holding the voxel centre.
    shell_meshes : bool
        Also compute the offset shells and write them to ``shells/`` (with the
        ``"distance"`` rule they run beside the voxels, in another process, and the
        manifest reports how well the two realisations agree).
    shell_method : {"robust", "paper"}
        Offset construction (see :mod:`offset`).
    margin_mm : float, mm
        Empty space around the model in the grid (at least the level-set half width).
    sdf_half_width_voxels : float
        Half width of the ``sdf`` level set's narrow band, in largest-voxel sizes.
    slab_mb : float
        Memory budget of one slab's working arrays; sets the slab height. Each worker
        holds about one slab at a time.
    workers : int
        Processes computing slabs at once (0: one per core; 1: in the calling process).
    alpha : bool
        Write ``colour.tif`` as RGBA instead of RGB.
    compression_level : int, optional
        zlib level of the TIFFs (1 fast .. 9 small); None (default): a compiled run
        encoder, several times faster, files up to twice the size (:mod:`voxel.deflate`).
    formats : tuple of {"tiff", "vdb", "gcvf", "png"}
        Files to write: ``tiff`` = ``layers.tif``, ``colour.tif`` and ``materials.tif``;
        ``vdb`` = ``volume.vdb``; ``gcvf`` = ``job.gcvf`` (GrabCAD Voxel Print);
        ``png`` = ``slices/`` (RGBA colour-and-translucency slices).
    material : MaterialSettings or None
        Separation and halftone of the voxels into the printer's materials (None: no
        materials, no ``materials.tif``, job or colour report).
    report_samples : int
        Surface samples of the colour report (0: none).
    optical_depth_mm : float, mm
        Optical depth ``L`` of the colour report's model (:mod:`voxel.colour_report`).
    """

    voxel_mm: tuple[float, float, float]
    printer: str | None = None
    thickness_mm: tuple[float, ...] = (0.5, 0.5)
    thickness_source: str = "--thickness"
    colour_layers: tuple[int, ...] = (1,)
    layer_rule: Literal["distance", "shells"] = "distance"
    shell_meshes: bool = True
    shell_method: Literal["robust", "paper"] = "robust"
    margin_mm: float = 0.5
    sdf_half_width_voxels: float = 3.0
    slab_mb: float = 1024.0
    workers: int = 0
    alpha: bool = False
    compression_level: int | None = None
    formats: tuple[str, ...] = ("tiff", "vdb")
    material: MaterialSettings | None = field(default_factory=MaterialSettings)
    report_samples: int = 20_000
    optical_depth_mm: float = 0.25

    def __post_init__(self) -> None:
        if len(self.voxel_mm) != 3 or not all(math.isfinite(v) and v > 0 for v in self.voxel_mm):
            raise ValueError(f"voxel_mm must be 3 positive lengths, got {self.voxel_mm}")
        if not self.thickness_mm or not all(t > 0 for t in self.thickness_mm):
            raise ValueError(f"thickness_mm must be positive lengths, got {self.thickness_mm}")
        top = len(self.thickness_mm) + 1
        if not self.colour_layers or not all(1 <= k <= top for k in self.colour_layers):
            raise ValueError(f"colour_layers must lie in 1..{top}, got {self.colour_layers}")
        if self.margin_mm < 0 or self.sdf_half_width_voxels < 0 or not 0 < self.slab_mb < math.inf:
            raise ValueError(
                "margin_mm and sdf_half_width_voxels must be >= 0 and slab_mb > 0, got "
                f"{self.margin_mm}, {self.sdf_half_width_voxels}, {self.slab_mb}"
            )
        if self.layer_rule not in ("distance", "shells"):
            raise ValueError(f"layer_rule must be 'distance' or 'shells', got {self.layer_rule!r}")
        if self.workers < 0:
            raise ValueError(f"workers must be >= 0 (0: one per core), got {self.workers}")
        if self.compression_level is not None and not 1 <= self.compression_level <= 9:
            raise ValueError(
                f"compression_level must be 1..9 or None, got {self.compression_level}"
            )
        unknown = set(self.formats) - set(FORMATS)
        if unknown:
            raise ValueError(f"formats must be among {FORMATS}, got {sorted(unknown)}")
        if self.report_samples < 0 or not self.optical_depth_mm > 0:
            raise ValueError(
                "report_samples must be >= 0 and optical_depth_mm > 0, got "
                f"{self.report_samples} and {self.optical_depth_mm}"
            )

    @property
    def write_vdb(self) -> bool:
        """Whether ``volume.vdb`` is written."""
        return "vdb" in self.formats

    @property
    def sdf_half_width_mm(self) -> float:
        """Narrow-band half width of the level set, mm."""
        return self.sdf_half_width_voxels * max(self.voxel_mm)
