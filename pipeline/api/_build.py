"""Build one model, or a tray of models, into a folder: what ``shellvox build`` does.

:class:`BuildOptions` holds every choice of the command (its defaults are the command's);
:func:`build` and :func:`build_tray` load, choose the thickness, and run the build
(:func:`shellvox.stack.build_stack`, :func:`shellvox.tray.build_tray`), returning what
was written as a :class:`BuildResult`.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from shellvox.api._thickness import ThicknessChoice, layer_thickness
from shellvox.config import (
    FORMATS,
    BuildConfig,
    LoadOptions,
    MaterialSettings,
    check_choice,
    check_flag,
    check_lengths,
    check_number,
)
from shellvox.errors import InputError, opt
from shellvox.loading import load_model
from shellvox.model import ColouredMesh
from shellvox.offset import MethodName
from shellvox.output import manifest_line
from shellvox.printer import PrinterProfile, load_profile
from shellvox.run import RunSettings
from shellvox.stack import build_stack
from shellvox.thickness import ThicknessRule
from shellvox.tray import (
    LayoutMode,
    ThicknessSource,
    TrayPlan,
    load_tray,
    plan_tray,
    tray_from_inputs,
)
from shellvox.tray import build_tray as build_tray_stack
from shellvox.voxel.slab import LayerRule

if TYPE_CHECKING:
    from shellvox.reading import Build


@dataclass(frozen=True)
class BuildOptions:
    """What to build and write: every choice of ``shellvox build`` but the files.

    Parameters
    ----------
    printer : str or Path
        Printer profile: a shipped name (``"j750"``, ``"j850"``, ``"j850-hq"``,
        ``"generic-cmykw"``) or a TOML file (``--printer``).
    voxel_size_mm : (3,) float or float, mm, optional
        Voxel size ``(x, y, z)`` instead of the printer's grid (then no printer job); one
        number is a cubic voxel (stored as the three sizes).
    formats : tuple of str, optional
        Files to write, among ``tiff``, ``vdb``, ``gcvf``, ``png``, ``zarr``; None: tiff,
        zarr, vdb and the printer's job format when the grid is the printer's.
    thickness_mm : tuple of float, mm, optional
        The same thickness of each layer on every face, outside in; None: the rule's.
    thickness_rule : ThicknessRule or Path, optional
        The per-face rule (default: the built-in optical rule).
    max_edge_mm : float, mm, optional
        Split faces of varying colour first (see :func:`shellvox.layer_thickness`).
    colour_layers : tuple of int, optional
        Layers (1..K+1) that take the surface colour (default: the rule's, or 1).
    layer_rule : {"distance", "shells"}
        A voxel's layer from its exact distance to the surface, or from the offset shells.
    shell_meshes : bool
        Also write the offset shells to ``shells/``.
    shell_method : {"field", "robust", "paper"}
        Offset construction of the shells.
    alpha : bool
        Write the colour as RGBA.
    materials : MaterialSettings or None
        Separation and halftone into the printer's materials; None: no materials (no
        ``materials.tif``, job or colour report).
    report_samples : int
        Surface samples of the colour report and the soft proof, at least (0: neither).
    proof_density : float, 1/mm^2
        Surface samples per mm^2 of the soft proof (``proof.ply``; 0: the report's only).
    slab_mb : float
        Working memory per slab and worker.
    compression_level : int, optional
        zlib level of the TIFFs (1..9); None: the fast setting.
    workers : int
        Processes computing slabs (0: one per core).
    """

    printer: str | Path = "j750"
    voxel_size_mm: tuple[float, float, float] | None = None
    formats: tuple[str, ...] | None = None
    thickness_mm: tuple[float, ...] | None = None
    thickness_rule: ThicknessRule | Path | None = None
    max_edge_mm: float | None = None
    colour_layers: tuple[int, ...] | None = None
    layer_rule: LayerRule = "distance"
    shell_meshes: bool = False
    shell_method: MethodName = "field"
    alpha: bool = False
    materials: MaterialSettings | None = field(default_factory=MaterialSettings)
    report_samples: int = 20_000
    proof_density: float = 12.0
    slab_mb: float = 1024.0
    compression_level: int | None = None
    workers: int = 0

    def __post_init__(self) -> None:
        """Check every value once, naming the parameter and the allowed values.

        A single voxel size is a cubic voxel (stored as the three sizes).
        """
        if not isinstance(self.printer, str | Path) or not str(self.printer):
            raise InputError(
                opt("printer"), f"got {self.printer!r}", "give a profile name or a .toml path"
            )
        if self.voxel_size_mm is not None:
            voxel = check_lengths("voxel_size", self.voxel_size_mm, count=3)
            object.__setattr__(self, "voxel_size_mm", voxel)
        if self.formats is not None:
            given: Any = self.formats
            chosen = (given,) if isinstance(given, str) else given
            if not isinstance(chosen, Iterable) or not chosen:
                chosen = (given,)
            for name in chosen:
                check_choice("formats", name, FORMATS)
            object.__setattr__(self, "formats", tuple(chosen))
        if self.thickness_mm is not None:
            object.__setattr__(self, "thickness_mm", check_lengths("thickness", self.thickness_mm))
        if not isinstance(self.thickness_rule, ThicknessRule | str | Path | None):
            raise InputError(
                opt("thickness_rule"),
                f"got {self.thickness_rule!r}",
                "give a ThicknessRule, the path of a rule file, or None (the default rule)",
            )
        if self.max_edge_mm is not None:
            check_number("max_edge", self.max_edge_mm, low=0, strict=True)
        if self.colour_layers is not None:
            layers: Any = self.colour_layers
            if isinstance(layers, numbers.Integral):
                layers = (layers,)
            if not isinstance(layers, Iterable) or not (layers := tuple(layers)):
                raise InputError(
                    opt("colour_layers"),
                    f"got {self.colour_layers!r}",
                    "give layer numbers from 1 (the outermost), e.g. (1,)",
                )
            for layer in layers:
                check_number("colour_layers", layer, low=1, integer=True)
            object.__setattr__(self, "colour_layers", tuple(int(k) for k in layers))
        check_choice("layer_rule", self.layer_rule, get_args(LayerRule))
        check_flag("shell_meshes", self.shell_meshes)
        check_choice("shell_method", self.shell_method, get_args(MethodName))
        check_flag("alpha", self.alpha)
        if not isinstance(self.materials, MaterialSettings | None):
            raise InputError(
                opt("materials"),
                f"got {self.materials!r}",
                "give MaterialSettings(...) or None (no materials)",
            )
        check_number("report_samples", self.report_samples, low=0, integer=True)
        check_number("proof_density", self.proof_density, low=0)
        check_number("slab_mb", self.slab_mb, low=0, strict=True)
        if self.compression_level is not None:
            check_number("compression_level", self.compression_level, low=1, high=9, integer=True)
        check_number("workers", self.workers, low=0, integer=True)

    def config(self, profile: PrinterProfile, choice: ThicknessChoice | None) -> BuildConfig:
        """Return the build's :class:`BuildConfig` for `profile` and the chosen thickness.

        Without `choice` (or with constant layers) the thickness is `thickness_mm`.
        """
        voxel = profile.voxel_mm if self.voxel_size_mm is None else self.voxel_size_mm
        if choice is None or choice.faces is None:
            thickness = self.thickness_mm or (0.5, 0.5)
            default_colour: tuple[int, ...] = (1,)
            source = "--thickness"
        else:
            thickness = tuple(float(np.median(row)) for row in choice.thickness_mm)
            default_colour = choice.faces.rule.layers.colour
            source = choice.source
        return BuildConfig(
            voxel_mm=voxel,
            printer=profile.name,
            thickness_mm=tuple(thickness),
            thickness_source=source,
            colour_layers=self.colour_layers or default_colour,
            layer_rule=self.layer_rule,
            shell_meshes=self.shell_meshes,
            shell_method=self.shell_method,
            alpha=self.alpha,
            formats=self.chosen_formats(profile),
            material=self.materials,
            report_samples=self.report_samples,
            proof_density=self.proof_density,
            slab_mb=self.slab_mb,
            compression_level=self.compression_level,
            workers=self.workers,
        )

    def chosen_formats(self, profile: PrinterProfile) -> tuple[str, ...]:
        """Return the formats to write (`formats`, or the default set) for `profile`.

        Raises
        ------
        InputError
            A printer job asked for off the printer's grid, or printer slices without
            materials.
        """
        voxel = profile.voxel_mm if self.voxel_size_mm is None else self.voxel_size_mm
        on_grid = all(
            math.isclose(a, b, rel_tol=1e-9) for a, b in zip(voxel, profile.voxel_mm, strict=True)
        )
        if self.formats is None:
            chosen = ["tiff", "zarr", "vdb"]
            if on_grid and self.materials is not None:
                chosen.append(profile.slice_format)
            return tuple(chosen)
        if "gcvf" in self.formats and not on_grid:
            raise InputError(
                opt("formats"),
                f"a .gcvf job needs the printer's grid {profile.voxel_mm} mm, got "
                f"{opt('voxel_size', tuple(voxel))}",
                f"drop {opt('voxel_size')} or the gcvf format",
            )
        if self.materials is None and {"gcvf", "png"} & set(self.formats):
            raise InputError(
                opt("formats"),
                "printer slices (gcvf, png) need materials",
                f"drop {opt('no_materials')} or those formats",
            )
        return tuple(dict.fromkeys(self.formats))  # unknown names: refused by BuildConfig


@dataclass(frozen=True)
class BuildResult:
    """What a build wrote.

    Attributes
    ----------
    folder : Path
        The output folder.
    manifest : dict
        ``folder/manifest.json`` as written: grid, layers, materials, files with their
        sizes and SHA-256, the colour report, timings.
    """

    folder: Path
    manifest: dict[str, Any]

    def __repr__(self) -> str:
        """One line: the folder, grid, voxel size, printer and files (not the manifest)."""
        return f"BuildResult({str(self.folder)!r}, {manifest_line(self.manifest)})"

    @property
    def files(self) -> tuple[Path, ...]:
        """Every file written, as paths (``manifest.json`` last)."""
        names = [name for name in self.manifest["files"] if name != "manifest.json"]
        return (*(self.folder / name for name in names), self.folder / "manifest.json")

    def open(self) -> Build:
        """Return the build as arrays (:func:`shellvox.open_build`)."""
        from shellvox.reading import open_build

        return open_build(self.folder)


def build(
    model: str | Path | ColouredMesh,
    out_dir: str | Path,
    options: BuildOptions | None = None,
    *,
    load: LoadOptions | None = None,
    running: RunSettings | None = None,
    progress: bool | None = None,
    force: bool = False,
    say: Callable[[str], None] | None = None,
) -> BuildResult:
    """Build a model's layered voxel stack and the printer's job into `out_dir`.

    Parameters
    ----------
    model : path or ColouredMesh
        A model file of any format :func:`shellvox.load_model` reads, or a loaded mesh.
    out_dir : path
        Output folder (created); an earlier build there is replaced as a whole.
    options : BuildOptions, optional
        What to build and write (default: as ``shellvox build`` with no options).
    load : LoadOptions, optional
        How the file is read (units, scale, colour, repair).
    running : RunSettings, optional
        Where the slabs run (a Dask scheduler), checkpoints and resume.
    progress : bool or None
        Show progress bars. None (the default): where a person is watching, when stderr
        is a terminal or in a Jupyter notebook (drawn by :mod:`tqdm.auto`); False: never;
        True: always.
    force : bool
        Build even when the estimate says memory or disk will not suffice.
    say : callable, optional
        Receives one line with the cost estimate before the work starts.

    Returns
    -------
    BuildResult

    Raises
    ------
    InputError
        A bad model, option, profile or rule, or a build this machine cannot hold.

    Examples
    --------
    >>> import shellvox
    >>> options = shellvox.BuildOptions(voxel_size_mm=(0.2, 0.2, 0.2), formats=("tiff", "zarr"))
    >>> result = shellvox.build(shellvox.data.colour_target(), "out", options)
    >>> sorted({p.relative_to(result.folder).parts[0] for p in result.files})
    ['colour.tif', 'layers.tif', 'manifest.json', 'materials.tif', 'proof.ply',
     'stack.ome.zarr', 'thickness.ply']
    >>> result.manifest["grid"]["voxel_size_mm"]
    [0.2, 0.2, 0.2]
    """
    options = options or BuildOptions()
    profile = load_profile(options.printer)
    options.config(profile, None)  # every option checked before the model is read
    out = _folder(out_dir)
    load = load or LoadOptions()
    mesh = model if isinstance(model, ColouredMesh) else load_model(model, load, check="solid")
    if mesh.solid is not None and (options.shell_meshes or options.layer_rule == "shells"):
        asked = "shell_meshes" if options.shell_meshes else "layer_rule"
        raise InputError(
            opt(asked),
            f"{mesh.source}: is not one closed, oriented part (read as it comes); its offset "
            "shells are not made",
            f"build it without {opt(asked)} (layers by distance, the default)",
        )
    choice = layer_thickness(
        mesh,
        thickness_mm=options.thickness_mm,
        rule=options.thickness_rule,
        max_edge_mm=options.max_edge_mm,
        printer=profile,
        materials=options.materials,
        max_faces=load.max_faces,
    )
    config = options.config(profile, choice)
    manifest = build_stack(
        choice.mesh,
        config,
        out,
        thickness=choice.thickness_mm,
        faces=choice.faces,
        profile=None if config.material is None else profile,
        progress=progress,
        force=force,
        say=say,
        running=running,
    )
    return BuildResult(out, manifest)


@dataclass(frozen=True)
class TrayRequest:
    """A tray's plan and what its build needs (see :func:`plan_tray_build`).

    Attributes
    ----------
    plan : TrayPlan
        The models, their places, the grid and the estimate (``plan.lines()`` says them).
    config : BuildConfig
        The build's configuration before each model's thickness is set.
    profile : PrinterProfile
        The printer.
    options : BuildOptions
        The choices the tray was planned with.
    load : LoadOptions
        How the files were read.
    seconds : float
        How long planning took (the models read and placed).
    """

    plan: TrayPlan
    config: BuildConfig
    profile: PrinterProfile
    options: BuildOptions
    load: LoadOptions
    seconds: float

    def __repr__(self) -> str:
        """One line: the models, the grid, voxel size and printer (not the plan's tables)."""
        grid = self.plan.grid
        voxel = tuple(float(f"{v:.4g}") for v in grid.voxel_mm)
        return (
            f"TrayRequest({len(self.plan.placements)} models, shape_zyx={grid.shape_zyx}, "
            f"voxel_mm={voxel}, printer={self.profile.name!r})"
        )


def plan_tray_build(
    models: Sequence[str | Path] | str | Path,
    out_dir: str | Path,
    options: BuildOptions | None = None,
    *,
    copies: int = 1,
    layout: Literal["auto", "given"] | None = None,
    gap_mm: float = 5.0,
    load: LoadOptions | None = None,
    force: bool = False,
) -> TrayRequest:
    """Plan a tray: read and place the models, estimate the build (nothing is built).

    Parameters
    ----------
    models : sequence of paths, or the path of a tray file (``.toml``)
        Model files (packed into the printer's tray), or a tray file naming each model
        with its position, rotation, scale, thickness and copies (``--tray``).
    out_dir : path
        Where the build would go (its file system must hold the files).
    options : BuildOptions, optional
        As :func:`build`; a tray is built with distance layers and no shell meshes.
    copies : int
        Copies of each model file (not with a tray file, which says its own).
    layout : {"auto", "given"}, optional
        Pack the models, or keep a tray file's positions (default: given for a tray
        file, packed for several models, kept for one).
    gap_mm : float, mm
        Gap between packed models.
    load : LoadOptions, optional
        How the files are read.
    force : bool
        Plan even when the estimate says memory or disk will not suffice.

    Returns
    -------
    TrayRequest

    Examples
    --------
    >>> import shellvox
    >>> request = shellvox.plan_tray_build([shellvox.data.colour_target()], "tray", copies=2)
    >>> len(request.plan.placements)
    2
    >>> print(request.plan.lines()[0])
    tray of 2 model(s), layout auto, gap 5 mm (at least 3.75 mm), printer tray 490 x 390 x 200 mm:
    """
    options = options or BuildOptions()
    started = time.perf_counter()
    profile = load_profile(options.printer)
    tray_file = isinstance(models, str | Path)
    if tray_file and copies != 1:
        raise InputError(opt("copies"), "is for model files", "set copies in the tray file")
    if options.layer_rule == "shells" or options.shell_meshes:
        raise InputError(
            opt("layer_rule", "shells") if options.layer_rule == "shells" else opt("shell_meshes"),
            "a tray is built with distance layers and without shell meshes",
            "drop it; run `shellvox shells` on each model for its shells",
        )
    if options.thickness_mm is not None and options.thickness_rule is not None:
        raise InputError(
            opt("thickness_rule"), f"cannot be combined with {opt('thickness')}", "drop one of them"
        )
    rule_path = options.thickness_rule
    if isinstance(rule_path, ThicknessRule):
        raise InputError(
            "thickness_rule",
            "a tray takes its rule as a file (each model may name its own)",
            "save the rule as TOML and give its path",
        )
    options.config(profile, None)  # every option checked before the models are read
    base = dataclasses.replace(options, colour_layers=None).config(profile, None)
    load = load or LoadOptions()
    out = _folder(out_dir)
    if isinstance(models, str | Path):
        spec = load_tray(Path(models))
    else:
        spec = tray_from_inputs([Path(m) for m in models], copies)
    mode: LayoutMode = layout or (
        "given" if tray_file else "auto" if spec.n_instances > 1 else "keep"
    )
    plan = plan_tray(
        spec,
        load,
        base,
        out,
        tray_mm=profile.tray_mm,
        mode=mode,
        gap_mm=gap_mm,
        default_thickness=ThicknessSource(options.thickness_mm, rule_path),
        colour_layers=options.colour_layers,
        force=force,
    )
    return TrayRequest(plan, base, profile, options, load, time.perf_counter() - started)


def build_tray(
    request: TrayRequest,
    out_dir: str | Path,
    *,
    running: RunSettings | None = None,
    progress: bool | None = None,
    force: bool = False,
    say: Callable[[str], None] | None = None,
) -> BuildResult:
    """Build a planned tray (:func:`plan_tray_build`) into `out_dir`: one stack, one job.

    Each model gets its own thickness (its tray entry's, or the options'); `running`,
    `progress`, `force` and `say` are as for :func:`build`.

    Examples
    --------
    >>> import shellvox
    >>> options = shellvox.BuildOptions(voxel_size_mm=(0.25, 0.25, 0.25), formats=("tiff",))
    >>> target = shellvox.data.colour_target()
    >>> request = shellvox.plan_tray_build([target, target], "tray", options, gap_mm=2.0)
    >>> len(request.plan.placements)
    2
    >>> [m["name"] for m in shellvox.build_tray(request, "tray").manifest["tray"]["models"]]
    ['colour_target.obj#1', 'colour_target.obj#2']
    """
    plan, profile, options = request.plan, request.profile, request.options
    meshes, thickness, faces = [], [], []
    for part in plan.parts:
        choice = layer_thickness(
            part.mesh,
            thickness_mm=part.thickness.constant_mm,
            rule=part.thickness.rule_path,
            max_edge_mm=options.max_edge_mm,
            printer=profile,
            materials=request.config.material,
            max_faces=request.load.max_faces,
        )
        meshes.append(choice.mesh)
        thickness.append(choice.thickness_mm)
        faces.append(choice.faces)
    config = dataclasses.replace(
        request.config,
        thickness_mm=(1.0,) * plan.parts[0].n_layers,  # set per face by the tray's build
        colour_layers=plan.parts[0].colour_layers,
        shell_meshes=False,
    )
    out = _folder(out_dir)
    manifest = build_tray_stack(
        plan,
        config,
        out,
        meshes=meshes,
        thickness=thickness,
        faces=faces,
        profile=None if config.material is None else profile,
        progress=progress,
        force=force,
        say=say,
        running=running,
    )
    return BuildResult(out, manifest)


def _folder(out_dir: str | Path) -> Path:
    """Return `out_dir` as a Path, refusing a file that is not a folder."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", f"choose another {opt('out')}")
    return out
