"""Offset shells as files with their report: what ``shellvox shells`` does.

In memory, shells are :func:`shellvox.offset.offset_shells`; :func:`write_shells` writes
them, reads them back and reports on them.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shellvox import __version__
from shellvox.api._thickness import layer_thickness
from shellvox.atomic import write_text_atomic
from shellvox.config import LoadOptions, ShellConfig, as_json
from shellvox.errors import InputError, opt
from shellvox.loading import load_model
from shellvox.offset import Shell, method_shells, ready_for_file, shell_report
from shellvox.output import (
    SHELL_OUTPUTS,
    OutputFolder,
    save_shells,
    sha256,
    write_thickness_ply,
)
from shellvox.thickness import ThicknessRule, thickness_summary


@dataclass(frozen=True)
class ShellsResult:
    """What :func:`write_shells` wrote.

    Attributes
    ----------
    folder : Path
    files : tuple of Path
        ``shell_1.ply`` ... (and ``thickness.ply`` with a rule), then ``report.json``.
    report : dict
        ``report.json``: the method, each shell's quality (closed, nested, crossings,
        distance to the surface against its depth) and the baselines.
    shells : tuple of Shell
        The shells as their files hold them, outside in.
    """

    folder: Path
    files: tuple[Path, ...]
    report: dict[str, Any]
    shells: tuple[Shell, ...]

    def __repr__(self) -> str:
        """One line: the folder, the method, the shells and the files (not the report)."""
        method = self.report.get("method")
        if isinstance(method, dict):  # the method's record: its name and how it ran
            method = method.get("method")
        return (
            f"ShellsResult({str(self.folder)!r}, method={method!r}, "
            f"{len(self.shells)} shells, files={tuple(p.name for p in self.files)})"
        )


def write_shells(
    model: str | Path,
    out_dir: str | Path,
    config: ShellConfig | None = None,
    *,
    thickness_rule: ThicknessRule | Path | None = None,
    max_edge_mm: float | None = None,
    printer: str | Path = "j750",
    baselines: bool = True,
    load: LoadOptions | None = None,
    say: Callable[[str], None] | None = None,
) -> ShellsResult:
    """Offset a model into shells, write them as PLY and measure them (``shellvox shells``).

    Parameters
    ----------
    model : path
        A model file.
    out_dir : path
        Output folder for ``shell_1.ply`` ..., ``report.json`` and, with a rule,
        ``thickness.ply``.
    config : ShellConfig, optional
        Constant layers (``thickness_mm``; empty: the rule's per face), the method, its
        grid step and the printer layer height of the slicer baseline.
    thickness_rule : ThicknessRule or Path, optional
        The per-face rule when `config` gives no constant layers (default: built in).
    max_edge_mm : float, mm, optional
        Split faces of varying colour first.
    printer : str or Path
        The printer whose optics the optical rule uses.
    baselines : bool
        Also measure the vertex-normal and slicer baselines.
    load : LoadOptions, optional
        How the file is read.
    say : callable, optional
        Receives a line as each stage starts.

    Returns
    -------
    ShellsResult

    Examples
    --------
    >>> import shellvox
    >>> config = shellvox.ShellConfig(thickness_mm=(0.5,), step_mm=0.2)
    >>> result = shellvox.write_shells(shellvox.data.colour_target(), "shells", config)
    >>> [p.name for p in result.files]
    ['shell_1.ply', 'report.json']
    >>> len(result.shells), result.report["method"]["method"]
    (1, 'field')
    """
    config = config or ShellConfig(thickness_mm=())
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(out, "exists and is not a folder", f"choose another {opt('out')}")
    load = load or LoadOptions()
    mesh = load_model(model, load)
    choice = layer_thickness(
        mesh,
        thickness_mm=config.thickness_mm or None,
        rule=thickness_rule,
        max_edge_mm=max_edge_mm,
        printer=printer,
        max_faces=load.max_faces,
    )
    tell = say or (lambda line: None)
    with OutputFolder(out, SHELL_OUTPUTS, marker="report.json") as folder:
        mesh, thickness = choice.mesh, choice.thickness_mm
        started = time.perf_counter()
        tell(f"offsetting {len(mesh.faces):,} faces into {len(thickness)} shells ({config.method})")
        made = method_shells(
            mesh.vertices, mesh.faces, thickness, method=config.method, step_mm=config.step_mm
        )
        offset_seconds = time.perf_counter() - started
        tell("cleaning, writing and reading back the shell files")
        ready = [ready_for_file(shell, config.method) for shell in made.shells]
        # the method's test of all shells together holds for shells written as made
        as_made = all(r.shell is s for r, s in zip(ready, made.shells, strict=True))
        written = save_shells(
            out,
            [r.shell for r in ready],
            cleaning=[r.cleaning for r in ready],
            crossing_free=made.crossing_free and as_made,
        )
        tell("measuring the shells" + (" and the baselines" if baselines else ""))
        report: dict[str, Any] = {
            "tool": f"shellvox {__version__}",
            "input": {"path": str(model), "sha256": sha256(Path(model)), "loaded": mesh.loaded},
            "config": as_json(config),
            "seconds": {"offset": offset_seconds},
            "method": made.record,
        }
        report.update(
            shell_report(
                mesh.vertices,
                mesh.faces,
                thickness,
                [w.shell for w in written],
                baselines=baselines,
                layer_height_mm=config.layer_height_mm,
                checks=[w.checks for w in written],
                crossing_free=made.crossing_free and as_made and all(w.as_given for w in written),
            )
        )
        for layer, w in zip(report["layers"], written, strict=True):
            # The report's "shell" entry is measured on the file as read back; this is
            # how it was written.
            layer["file"] = {
                "path": w.path.name,
                "format": "binary_little_endian PLY, property double x/y/z",
                "bytes": w.path.stat().st_size,
                "cleaning": w.cleaning,
            }
        files = [w.path for w in written]
        if choice.faces is not None:
            report["thickness"] = {"source": choice.source, **thickness_summary(choice.faces)}
            write_thickness_ply(out / "thickness.ply", mesh, choice.faces)
            files.append(out / "thickness.ply")
        report["seconds"]["total"] = time.perf_counter() - started
        report["files"] = folder.commit(files)
        write_text_atomic(out / "report.json", json.dumps(report, indent=2))
    shells = tuple(w.shell for w in written)
    return ShellsResult(out, (*files, out / "report.json"), report, shells)
