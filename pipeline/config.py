"""Frozen configuration objects; each serialises to the manifest with :func:`as_json`.

:class:`LoadOptions` (how a model is read, every command), :class:`ShellConfig`
(``shellvox shells``) and :class:`BuildConfig` (``shellvox build``). Each checks its values
once, where it is made, and names the option in the error (:func:`shellvox.errors.opt`:
the parameter from Python, the flag from the command line) with the allowed values.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Hashable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np

from shellvox.errors import InputError, opt
from shellvox.voxel.colour import DEFAULT_TILE, HALFTONES, Halftone
from shellvox.voxel.slab import LayerRule

#: Material roles of a printer profile (:mod:`shellvox.printer._profile`).
Role = Literal["cyan", "magenta", "yellow", "black", "white", "clear", "support", "void"]

Unit = Literal["micron", "mm", "cm", "m", "inch", "foot"]

#: An axis of the file that points up (``--up``): it is turned to +Z.
Up = Literal["x", "y", "z", "-x", "-y", "-z"]
#: The up axes, in the order the command line offers them.
UP_AXES: tuple[Up, ...] = get_args(Up)

#: Millimetres per unit.
UNIT_MM: dict[str, float] = {
    "micron": 1e-3,
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "inch": 25.4,
    "foot": 304.8,
}


def check_choice(name: str, value: Any, choices: Iterable[Any]) -> None:
    """Refuse `value` unless it is one of `choices`, naming option `name` and the choices.

    Raises
    ------
    InputError
        Naming the option (:func:`shellvox.errors.opt`) and the allowed values.
    """
    allowed = tuple(choices)
    if not isinstance(value, Hashable) or value not in allowed:
        raise InputError(
            opt(name), f"got {value!r}", "choose among " + ", ".join(map(repr, allowed))
        )


def check_flag(name: str, value: Any, *, optional: bool = False) -> None:
    """Refuse `value` unless it is True or False (or None when `optional`)."""
    if not (isinstance(value, bool | np.bool_) or (optional and value is None)):
        allowed = "True, False or None" if optional else "True or False"
        raise InputError(opt(name), f"got {value!r}", f"give {allowed}")


def check_number(
    name: str,
    value: Any,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    strict: bool = False,
    integer: bool = False,
) -> None:
    """Refuse `value` unless it is a finite number (an integer if asked) in a range.

    Parameters
    ----------
    name : str
        The option (a key of :data:`shellvox.errors.OPTIONS`).
    value : object
        What the user gave.
    low, high : float
        The range, `high` included; `low` included unless `strict`.
    strict : bool
        Refuse `low` itself (a positive number: ``low=0, strict=True``).
    integer : bool
        Refuse numbers that are not integers (booleans are never numbers here).
    """
    kind = numbers.Integral if integer else numbers.Real
    above = "above" if strict else "at least"
    wanted = ("an integer" if integer else "a number") + (
        f" {above} {low:g}" if low > -math.inf else ""
    )
    if high < math.inf:
        wanted += f" and at most {high:g}"
    fine = not isinstance(value, bool | np.bool_) and isinstance(value, kind)
    number = float(value) if fine else math.nan
    if not (math.isfinite(number) and (number > low if strict else number >= low)) or not (
        number <= high
    ):
        raise InputError(opt(name), f"got {value!r}", f"give {wanted}")


def _positive(value: Any) -> bool:
    """Whether `value` is a positive finite number (not a boolean)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        return False
    return math.isfinite(float(value)) and float(value) > 0


def _byte(value: Any) -> bool:
    """Whether `value` is an integer in 0..255 (not a boolean)."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        return False
    return 0 <= int(value) <= 255


def check_lengths(
    name: str, value: Any, *, count: int | None = None, empty: bool = False
) -> tuple[float, ...]:
    """Return `value` as a tuple of positive finite lengths, refusing anything else.

    A single number stands for each of `count` lengths (a cubic voxel from one size);
    without `count` a sequence of any length is accepted, an empty one only if `empty`.

    Returns
    -------
    tuple of float
    """
    items: Any = value
    if count is not None and not isinstance(value, bool) and isinstance(value, numbers.Real):
        items = (value,) * count
    example = opt(name, (0.5,) * (count or 2))
    shape = f"{count} positive lengths" if count else "positive lengths (one or more)"
    if isinstance(items, str | bytes) or not isinstance(items, Iterable):
        raise InputError(opt(name), f"got {value!r}", f"give {shape} in mm, e.g. {example}")
    items = tuple(items)
    good = all(_positive(v) for v in items)
    if not good or not (items or empty) or (count is not None and len(items) != count):
        raise InputError(opt(name), f"got {value!r}", f"give {shape} in mm, e.g. {example}")
    return tuple(float(v) for v in items)


@dataclass(frozen=True)
class LoadOptions:
    """How to read a model; the same options on every command that reads one.

    Parameters
    ----------
    units : Unit or None
        Unit of the file's coordinates when the format does not declare one
        (default millimetres). 3MF declares its own unit, glTF is in metres.
    scale : float
        Extra factor applied after unit conversion (``--scale``).
    size_mm : float or None, mm
        Scale the model uniformly so that the longest side of its bounding box is this
        long (``--size``, a slicer's scale-to-fit), whatever the file's unit; it cannot
        be combined with a `scale` other than 1. None: the file's size in its unit.
    up : {"x", "y", "z", "-x", "-y", "-z"} or None
        The file's axis that points up, turned to +Z by a rotation (``--up``). None: the
        format's (+Y for glTF, as its specification says; +Z for the others).
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
    size_mm: float | None = None
    up: Up | None = None
    colour: tuple[int, int, int, int] | None = None
    texture: Path | None = None
    repair: bool = False
    force: bool = False
    max_faces: int = 5_000_000

    def __post_init__(self) -> None:
        """Check every value once, naming the parameter and the allowed values."""
        if self.units is not None:
            check_choice("units", self.units, UNIT_MM)
        check_number("scale", self.scale, low=0, strict=True)
        if self.size_mm is not None:
            check_number("size", self.size_mm, low=0, strict=True)
            if self.scale != 1:
                raise InputError(
                    opt("size"),
                    f"sets the model's size, and {opt('scale', self.scale)} would change it again",
                    f"pass one of {opt('size')} and {opt('scale')}",
                )
        if self.up is not None:
            check_choice("up", self.up, UP_AXES)
        if self.colour is not None:
            colour: Any = self.colour
            if isinstance(colour, str | bytes) or not isinstance(colour, Iterable):
                colour = ()
            values = tuple(colour)
            if len(values) not in (3, 4) or not all(_byte(v) for v in values):
                raise InputError(
                    opt("colour"),
                    f"got {self.colour!r}",
                    "give 3 or 4 integers in 0-255 (red, green, blue and alpha), "
                    f"e.g. {opt('colour', (200, 30, 30))}",
                )
            object.__setattr__(self, "colour", tuple(int(v) for v in (*values, 255)[:4]))
        if self.texture is not None:
            if not isinstance(self.texture, str | Path):
                raise InputError(
                    opt("texture"), f"got {self.texture!r}", "give the image file's path"
                )
            object.__setattr__(self, "texture", Path(self.texture))
        check_flag("repair", self.repair)
        check_flag("force", self.force)
        check_number("max_faces", self.max_faces, low=1, integer=True)


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


def _check_method(method: str, *, closed: bool = True, name: str = "method") -> None:
    """Raise unless `method` is a method (:data:`shellvox.offset.METHODS`), closed if asked.

    `name` is the option that sets it (a key of :data:`shellvox.errors.OPTIONS`).
    """
    from shellvox.offset import METHODS

    check_choice(name, method, METHODS)
    if closed and not METHODS[method].closed:
        usable = " or ".join(opt(name, m.name) for m in METHODS.values() if m.closed)
        raise InputError(
            opt(name),
            f"{method}'s shells are not closed surfaces, which shell files and layers need",
            f"use {usable}",
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
        """Check every value once, naming the parameter and the allowed values."""
        object.__setattr__(
            self, "thickness_mm", check_lengths("thickness", self.thickness_mm, empty=True)
        )
        _check_method(self.method)
        if self.step_mm is not None:
            check_number("shell_step", self.step_mm, low=0, strict=True)
        check_number("layer_height", self.layer_height_mm, low=0, strict=True)


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
        """Check every value once, naming the parameter and the allowed values."""
        check_choice("halftone", self.halftone, HALFTONES)
        check_number("seed", self.seed, low=0, integer=True)
        if self.icc is not None:
            if not isinstance(self.icc, str | Path):
                raise InputError(opt("icc"), f"got {self.icc!r}", "give the ICC file's path")
            object.__setattr__(self, "icc", Path(self.icc))
        for name, role in (("backing", self.backing_role), ("core", self.core_role)):
            if role is not None:
                check_choice(name, role, get_args(Role))
        check_number("tile_size", self.tile_size, low=1, integer=True)


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
        """Check every value once, naming the option that sets it."""
        voxel = check_lengths("voxel_size", self.voxel_mm, count=3)
        object.__setattr__(self, "voxel_mm", voxel)
        if not self.thickness_mm or not all(t > 0 for t in self.thickness_mm):
            raise InputError(
                opt("thickness"),
                f"expected positive lengths, got {self.thickness_mm}",
                f"pass lengths in mm such as {opt('thickness', (0.5, 0.5))}",
            )
        top = len(self.thickness_mm) + 1
        if not self.colour_layers or not all(1 <= k <= top for k in self.colour_layers):
            raise InputError(
                opt("colour_layers"),
                f"expected layer numbers in 1..{top}, got "
                f"{','.join(map(str, self.colour_layers))!r}",
                f"pass e.g. {opt('colour_layers', (1,))}",
            )
        if self.margin_mm < 0 or self.sdf_half_width_voxels < 0:
            raise InputError(
                "margin_mm, sdf_half_width_voxels",
                f"must be >= 0, got {self.margin_mm} and {self.sdf_half_width_voxels}",
                "pass 0 or more",
            )
        check_number("slab_mb", self.slab_mb, low=0, strict=True)
        check_choice("layer_rule", self.layer_rule, get_args(LayerRule))
        _check_method(
            self.shell_method,
            closed=self.shell_meshes or self.layer_rule == "shells",
            name="shell_method",
        )
        check_number("workers", self.workers, low=0, integer=True)
        if self.compression_level is not None:
            check_number("compression_level", self.compression_level, low=1, high=9, integer=True)
        unknown = sorted(set(self.formats) - set(FORMATS))
        if unknown or not self.formats:
            raise InputError(
                opt("formats"),
                f"unknown format(s) {unknown} in {list(self.formats)}",
                "choose among " + ", ".join(FORMATS) + f", e.g. {opt('formats', ('tiff', 'gcvf'))}",
            )
        check_number("report_samples", self.report_samples, low=0, integer=True)
        check_number("proof_density", self.proof_density, low=0)
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
