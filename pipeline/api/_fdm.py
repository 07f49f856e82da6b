"""Colour-skin projects for FDM slicers: what ``shellvox fdm`` does (:func:`fdm_projects`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shellvox import __version__
from shellvox.api._thickness import layer_thickness
from shellvox.atomic import write_text_atomic
from shellvox.config import LoadOptions, as_json
from shellvox.errors import InputError, opt
from shellvox.fdm import (
    SLICERS,
    FdmProject,
    FdmSettings,
    Filaments,
    check_slicers,
    make_project,
    parse_filaments,
    write_projects,
)
from shellvox.fdm._project import check_filament_count
from shellvox.loading import load_model
from shellvox.offset import MethodName
from shellvox.output import sha256
from shellvox.thickness import ThicknessRule


@dataclass(frozen=True, eq=False)
class FdmResult:
    """What :func:`fdm_projects` wrote.

    Attributes
    ----------
    files : tuple of Path
        ``<stem>_prusa.3mf`` and/or ``<stem>_bambu.3mf``.
    project : FdmProject
        Each face's skin filament and depth, and the volumes of the object.
    manifest : dict
        ``manifest.json`` beside them: the tool, the input (path, SHA-256), the filaments,
        the slicers, the settings, the shell method of the core and the files.
    """

    files: tuple[Path, ...]
    project: FdmProject
    manifest: dict[str, Any]

    def __repr__(self) -> str:
        """One line: the faces, the filaments and the files (not the project's arrays)."""
        return (
            f"FdmResult({len(self.project.face_filament)} faces, filaments "
            f"{','.join(self.project.filaments.hex)}, files={tuple(p.name for p in self.files)})"
        )


def fdm_projects(
    model: str | Path,
    out_dir: str | Path,
    filaments: Filaments | str,
    *,
    settings: FdmSettings | None = None,
    slicers: Sequence[str] = SLICERS,
    thickness_mm: float | None = None,
    thickness_rule: ThicknessRule | Path | None = None,
    max_edge_mm: float | None = None,
    printer: str | Path = "j750",
    method: MethodName = "field",
    dither: bool = False,
    load: LoadOptions | None = None,
) -> FdmResult:
    """Write a 3MF project per FDM slicer: a colour skin per face over a core.

    Parameters
    ----------
    model : path
        A coloured model file.
    out_dir : path
        Output folder (created).
    filaments : Filaments or str
        The filament colours, the core's first (``"#FFFFFF,#00A0E0,..."``).
    settings : FdmSettings, optional
        Layer height and nozzle width (default 0.2 and 0.4 mm).
    slicers : sequence of {"prusa", "bambu"}
        Which projects to write (PrusaSlicer; Bambu Studio and OrcaSlicer).
    thickness_mm : float, mm, optional
        The skin's depth on every face (default: the colour layer of the thickness rule,
        raised to one extrusion width where thinner).
    thickness_rule, max_edge_mm, printer
        As :func:`shellvox.layer_thickness`.
    method : {"field", "robust", "paper"}
        Offset construction of the core (:data:`shellvox.offset.METHODS`; default
        ``"field"``, as every command).
    dither : bool
        Dither the filament choice over neighbouring faces (error diffusion).
    load : LoadOptions, optional
        How the file is read.

    Returns
    -------
    FdmResult

    Examples
    --------
    >>> import shellvox
    >>> result = shellvox.fdm_projects(
    ...     shellvox.data.colour_target(), "fdm", "#FFFFFF,#E03020,#2050C0", slicers=["prusa"]
    ... )
    >>> [p.name for p in result.files]
    ['colour_target_prusa.3mf']
    """
    chosen = parse_filaments(filaments) if isinstance(filaments, str) else filaments
    slicers = check_slicers([s.strip() for s in slicers])
    check_filament_count(chosen, slicers)  # refused before any work
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", f"choose another {opt('out')}")
    load = load or LoadOptions()
    path = Path(model)
    mesh = load_model(path, load)
    choice = layer_thickness(
        mesh,
        thickness_mm=None if thickness_mm is None else (thickness_mm,),
        rule=thickness_rule,
        max_edge_mm=max_edge_mm,
        printer=printer,
        max_faces=load.max_faces,
    )
    project = make_project(
        choice.mesh,
        choice.thickness_mm[0],
        chosen,
        settings=settings,
        slicers=slicers,
        method=method,
        dither=dither,
        lift=choice.faces is not None,
        name=path.stem,
    )
    out.mkdir(parents=True, exist_ok=True)
    files = tuple(write_projects(out, path.stem, project, slicers))
    manifest = {
        "tool": f"shellvox {__version__}",
        "input": {"path": str(path), "sha256": sha256(path), "loaded": mesh.loaded},
        "filaments": list(chosen.hex),
        "slicers": list(slicers),
        "settings": as_json(settings or FdmSettings()),
        "thickness": "--thickness" if thickness_mm is not None else "the thickness rule",
        "shell_method": method,
        "files": [file.name for file in files],
    }
    write_text_atomic(out / "manifest.json", json.dumps(manifest, indent=2) + "\n")
    return FdmResult(files, project, manifest)
