"""Frozen configuration objects; each serialises to the manifest with :func:`as_json`.

:class:`LoadOptions` (how a model is read, every command), :class:`ShellConfig`
(``shellvox shells``) and :class:`BuildConfig` (``shellvox build``). Each checks its values
once, here, and names the command-line option in the error.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

from shellvox.errors import InputError
from shellvox.voxel.colour import DEFAULT_TILE, HALFTONES, Halftone
from shellvox.voxel.slab import LayerRule

#: Material roles of a printer profile (:mod:`shellvox.printer._profile`).
Role = Literal["cyan", "magenta", "yellow", "black", "white", "clear", "support", "void"]

Unit = Literal["micron", "mm", "cm", "m", "inch", "foot"]

#: Millimetres per unit.
UNIT_MM: dict[str, float] = {
    "micron": 1e-3,
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "inch": 25.4,
    "foot": 304.8,
}


@dataclass(frozen=True)
class LoadOptions:
    """How to read a model; the same options on every command that reads one.

    Parameters
    ----------
    units : Unit or None
        Unit of the file's coordinates when the format does not declare one
        (default millimetres). A 3MF declares its own unit.
    scale : float
        Extra factor applied after unit conversion (``--scale``).
    colour : tuple of 4 int or None
        sRGB + alpha for a model without colour (``--colour``), or the fallback colour
        when a texture is missing (then with a warning).
    texture : Path or None
        Texture image to use when an OBJ has no MTL or its ``map_Kd`` is missing.
    repair : bool
        Close small holes and fix inconsistent winding (with a warning) instead of refusing.
    force : bool
        Lift the loader's limits (:attr:`max_faces`, the texture pixel budget, coordinates
        beyond 1e6 mm) and read referenced files outside the model's folder, with a
        warning (see :mod:`shellvox.loading`).
    max_faces : int
        Sane face limit without ``force``.
    """

    units: Unit | None = None
    scale: float = 1.0
    colour: tuple[int, int, int, int] | None = None
    texture: Path | None = None
    repair: bool = False
    force: bool = False
    max_faces: int = 5_000_000


def as_json(config: Any) -> dict[str, Any]:
    """Return a JSON-serialisable dict of a frozen config dataclass (paths as strings)."""

    def convert(value: Any) -> Any:
        if isinstance(value, Path):
            return str(value)
        if isinstance(value, tuple | list):
            return [convert(item) for item in value]
        if isinstance(value, dict):
            return {key: convert(item) for key, item in value.items()}
        return value

    return {key: convert(value) for key, value in dataclasses.asdict(config).items()}


def _check_method(method: str, *, closed: bool = True) -> None:
    """Raise unless `method` is a method (:data:`shellvox.offset.METHODS`), closed if asked."""
    from shellvox.offset import METHODS

    if method not in METHODS:
        raise InputError("--method", f"got {method!r}", f"choose among {', '.join(METHODS)}")
    if closed and not METHODS[method].closed:
        usable = " or ".join(m.name for m in METHODS.values() if m.closed)
        raise InputError(
            "--method",
            f"{method}'s shells are not closed surfaces, which shell files and layers need",
            f"use --method {usable}",
        )


@dataclass(frozen=True)
class ShellConfig:
    """How shells are made (``shellvox shells``; the shell stage of ``build``).

    Parameters
    ----------
    thickness_mm : tuple of float
        Thickness of each layer, outside in (mm), the same for every face (``--thickness``);
        empty when a thickness rule sets it per face.
    method : {"field", "robust", "paper"}
        Offset construction, a name of :data:`shellvox.offset.METHODS`.
    step_mm : float or None, mm
        Grid step of the ``field`` method (None: automatic, see
        :func:`shellvox.offset.automatic_step`).
    layer_height_mm : float
        Printer layer height used by the slicer baseline of the report.
    """

    thickness_mm: tuple[float, ...] = (0.5, 0.5)
    method: Literal["field", "robust", "paper"] = "field"
    step_mm: float | None = None
    layer_height_mm: float = 0.027

    def __post_init__(self) -> None:
        _check_method(self.method)


#: Output formats ``build`` can write (``--format``).
FORMATS = ("tiff", "vdb", "gcvf", "png", "zarr")


@dataclass(frozen=True)
class MaterialSettings:
    """User choices for materials; each ``None`` falls back to the profile.

    Parameters
    ----------
    halftone : {"blue-noise", "error-diffusion"}
        See :mod:`shellvox.voxel.colour._materials`.
    seed : int
        Seed of the blue-noise tile (the halftone is deterministic per seed).
    icc : Path or None
        CMYK ICC output profile for the separation instead of the mixing model.
    backing_role, core_role : Role or None
        Material role of the backing layers and of the core (default: the profile's).
    tile_size : int
        Blue-noise tile edge in voxels.
    """

    halftone: Halftone = "blue-noise"
    seed: int = 0
    icc: Path | None = None
    backing_role: Role | None = None
    core_role: Role | None = None
    tile_size: int = DEFAULT_TILE

    def __post_init__(self) -> None:
        if self.halftone not in HALFTONES:
            raise InputError(
                "--halftone", f"must be one of {list(HALFTONES)}, got {self.halftone!r}", "fix it"
            )
        if self.seed < 0:
            raise InputError("--seed", f"must be >= 0, got {self.seed}", "give 0 or more")


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
        Also write the offset shells to ``shells/`` (the ``"shells"`` rule computes them
        anyway; with the ``"distance"`` rule they run beside the voxels, in another
        process, and the manifest reports how well the two realisations agree).
    shell_method : {"field", "robust", "paper"}
        Offset construction (:data:`shellvox.offset.METHODS`; ``field``, the
        default, on its default grid step, ``--shell-step`` of ``shellvox shells``).
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
        zlib level of the TIFFs (1 fast .. 9 small); None (default): the fast
        setting of :mod:`shellvox.voxel.io._compression` (zlib-ng's level 2).
    formats : tuple of {"tiff", "vdb", "gcvf", "png", "zarr"}
        Files to write: ``tiff`` = ``layers.tif``, ``colour.tif`` and ``materials.tif``;
        ``vdb`` = ``volume.vdb``; ``gcvf`` = ``job.gcvf`` (GrabCAD Voxel Print);
        ``png`` = ``slices/`` (RGBA colour-and-translucency slices); ``zarr`` =
        ``stack.ome.zarr/`` (OME-Zarr 0.5: colour, materials and layers, multiscale).
    material : MaterialSettings or None
        Separation and halftone of the voxels into the printer's materials (None: no
        materials, no ``materials.tif``, job or colour report).
    report_samples : int
        Surface samples of the colour report and its soft proof, at least (0: neither).
    proof_density : float, 1/mm^2
        Surface samples per mm^2 of the soft proof (``proof.ply``), at most 250,000 in
        all (:data:`shellvox.voxel.colour.PROOF_SAMPLES_PER_MM2`); 0: the report's
        samples only.
    optical_depth_mm : float, mm
        Optical depth ``L`` of the colour report's model (:mod:`shellvox.voxel.colour._report`).
    """

    voxel_mm: tuple[float, float, float]
    printer: str | None = None
    thickness_mm: tuple[float, ...] = (0.5, 0.5)
    thickness_source: str = "--thickness"
    colour_layers: tuple[int, ...] = (1,)
    layer_rule: LayerRule = "distance"
    shell_meshes: bool = False
    shell_method: Literal["field", "robust", "paper"] = "field"
    margin_mm: float = 0.5
    sdf_half_width_voxels: float = 3.0
    slab_mb: float = 1024.0
    workers: int = 0
    alpha: bool = False
    compression_level: int | None = None
    formats: tuple[str, ...] = ("tiff", "vdb")
    material: MaterialSettings | None = field(default_factory=MaterialSettings)
    report_samples: int = 20_000
    proof_density: float = 12.0
    optical_depth_mm: float = 0.25

    def __post_init__(self) -> None:
        """Check every value once, naming the command-line option that sets it."""
        if len(self.voxel_mm) != 3 or not all(math.isfinite(v) and v > 0 for v in self.voxel_mm):
            raise InputError(
                "--voxel-size",
                f"expected 3 positive lengths, got {self.voxel_mm}",
                "pass sizes in mm such as 0.05,0.05,0.03",
            )
        if not self.thickness_mm or not all(t > 0 for t in self.thickness_mm):
            raise InputError(
                "--thickness",
                f"expected positive lengths, got {self.thickness_mm}",
                "pass lengths in mm such as 0.5,0.5",
            )
        top = len(self.thickness_mm) + 1
        if not self.colour_layers or not all(1 <= k <= top for k in self.colour_layers):
            raise InputError(
                "--colour-layers",
                f"expected layer numbers in 1..{top}, got "
                f"{','.join(map(str, self.colour_layers))!r}",
                "pass e.g. --colour-layers 1",
            )
        if self.margin_mm < 0 or self.sdf_half_width_voxels < 0:
            raise InputError(
                "margin_mm, sdf_half_width_voxels",
                f"must be >= 0, got {self.margin_mm} and {self.sdf_half_width_voxels}",
                "pass 0 or more",
            )
        if not 0 < self.slab_mb < math.inf:
            raise InputError(
                "--slab-mb", f"got {self.slab_mb}", "give a positive finite slab size in MB"
            )
        if self.layer_rule not in get_args(LayerRule):
            raise InputError(
                "--layers", f"got {self.layer_rule!r}", f"choose among {get_args(LayerRule)}"
            )
        _check_method(self.shell_method, closed=self.shell_meshes or self.layer_rule == "shells")
        if self.workers < 0:
            raise InputError("--workers", f"got {self.workers}", "give 0 (one per core) or more")
        if self.compression_level is not None and not 1 <= self.compression_level <= 9:
            raise InputError(
                "--compression-level", f"got {self.compression_level}", "use a level in 1..9"
            )
        unknown = sorted(set(self.formats) - set(FORMATS))
        if unknown or not self.formats:
            raise InputError(
                "--format",
                f"unknown format(s) {unknown} in {list(self.formats)}",
                "choose among " + ",".join(FORMATS) + ", e.g. --format tiff,gcvf",
            )
        if self.report_samples < 0:
            raise InputError("--report-samples", f"got {self.report_samples}", "give 0 or more")
        if not (math.isfinite(self.proof_density) and self.proof_density >= 0):
            raise InputError(
                "--proof-density", f"got {self.proof_density}", "give samples per mm^2, 0 or more"
            )
        if not self.optical_depth_mm > 0:
            raise InputError(
                "optical_depth_mm", f"got {self.optical_depth_mm}", "give a positive length"
            )

    @property
    def write_vdb(self) -> bool:
        """Whether ``volume.vdb`` is written."""
        return "vdb" in self.formats

    @property
    def sdf_half_width_mm(self) -> float:
        """Narrow-band half width of the level set, mm."""
        return self.sdf_half_width_voxels * max(self.voxel_mm)
