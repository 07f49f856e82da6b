"""The one error type for bad input, the warning type, and how both name options.

An :class:`InputError` is one line naming the file, the problem and the fix. Where the
text names an option the user can set, it holds a marker (:func:`opt`) instead of a
spelling, and each front end words it: ``str(error)`` in Python's words
(``LoadOptions(repair=True)``), the command line in its flags (``--repair``; see
:meth:`InputError.words`). :class:`ShellvoxWarning` does the same, and :func:`warn`
attributes every warning of the package to the caller's line.
"""

from __future__ import annotations

import re
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

#: The two front ends that word a message.
Front = Literal["python", "cli"]


@dataclass(frozen=True)
class Option:
    """One option the user can set, spelled for each front end.

    Parameters
    ----------
    cli : str or None
        The command-line flag (``"--scale"``); None: not settable from the command line
        (the command line then shows the Python spelling).
    python : str
        The Python spelling with ``{}`` where the value goes (``"LoadOptions(scale={})"``);
        a switch has no ``{}`` (``"LoadOptions(repair=True)"``).
    cli_meta : str
        What follows the flag when no value is given (``"DIR"`` after ``-o``).
    """

    cli: str | None
    python: str
    cli_meta: str = ""

    def spell(self, front: Front, value: str | None = None, python: str | None = None) -> str:
        """Return the option in the words of `front`, with the value if one is given."""
        if front == "cli" and self.cli is not None:
            shown = self.cli_meta if value is None else value
            return f"{self.cli} {shown}".rstrip()
        return self.python.format(python or "...")


#: Every option a message can name: its name (the key of :func:`opt`) and spellings.
OPTIONS: dict[str, Option] = {
    # LoadOptions (every command that reads a model)
    "units": Option("--units", "LoadOptions(units={})"),
    "scale": Option("--scale", "LoadOptions(scale={})"),
    "colour": Option("--colour", "LoadOptions(colour={})", "R,G,B"),
    "texture": Option("--texture", "LoadOptions(texture={})"),
    "repair": Option("--repair", "LoadOptions(repair=True)"),
    "force": Option("--force", "LoadOptions(force=True)"),
    "max_faces": Option("--max-faces", "LoadOptions(max_faces={})"),
    "size": Option("--size", "LoadOptions(size_mm={})", "MM"),
    "up": Option("--up", "LoadOptions(up={})"),
    # the output folder and the run
    "out": Option("-o", "out_dir={}", "DIR"),
    "force_run": Option("--force", "force=True"),
    "resume": Option("--resume", "RunSettings(resume=True)"),
    "scheduler": Option("--scheduler", "RunSettings(scheduler={})"),
    "checkpoint": Option("--checkpoint", "RunSettings(checkpoint={})"),
    # BuildOptions
    "printer": Option("--printer", "printer={}"),
    "voxel_size": Option("--voxel-size", "BuildOptions(voxel_size_mm={})"),
    "formats": Option("--format", "BuildOptions(formats={})"),
    "no_vdb": Option("--no-vdb", "BuildOptions(formats=...) without 'vdb'"),
    "thickness": Option("--thickness", "thickness_mm={}"),
    "thickness_rule": Option("--thickness-rule", "thickness_rule={}"),
    "max_edge": Option("--max-edge", "max_edge_mm={}"),
    "colour_layers": Option("--colour-layers", "BuildOptions(colour_layers={})"),
    "layer_rule": Option("--layers", "BuildOptions(layer_rule={})"),
    "shell_meshes": Option("--shell-meshes", "BuildOptions(shell_meshes=True)"),
    "shell_method": Option("--method", "BuildOptions(shell_method={})"),
    "method": Option("--method", "ShellConfig(method={})"),
    "alpha": Option("--alpha", "BuildOptions(alpha=True)"),
    "no_materials": Option("--no-materials", "BuildOptions(materials=None)"),
    "materials": Option(None, "BuildOptions(materials={})"),
    "report_samples": Option("--report-samples", "BuildOptions(report_samples={})"),
    "proof_density": Option("--proof-density", "BuildOptions(proof_density={})"),
    "slab_mb": Option("--slab-mb", "BuildOptions(slab_mb={})"),
    "compression_level": Option("--compression-level", "BuildOptions(compression_level={})"),
    "workers": Option("--workers", "BuildOptions(workers={})"),
    # MaterialSettings
    "halftone": Option("--halftone", "MaterialSettings(halftone={})"),
    "seed": Option("--seed", "MaterialSettings(seed={})"),
    "icc": Option("--icc", "MaterialSettings(icc={})"),
    "backing": Option("--backing", "MaterialSettings(backing_role={})"),
    "core": Option("--core", "MaterialSettings(core_role={})"),
    "tile_size": Option(None, "MaterialSettings(tile_size={})"),
    # ShellConfig (shellvox shells)
    "shell_step": Option("--shell-step", "ShellConfig(step_mm={})"),
    "layer_height": Option("--layer-height", "ShellConfig(layer_height_mm={})"),
    # trays
    "tray": Option("--tray", "the tray file {}"),
    "copies": Option("--copies", "plan_tray_build(copies={})"),
    "layout": Option("--layout", "plan_tray_build(layout={})"),
    # fdm_projects (shellvox fdm) and calibrate
    "filaments": Option("--filaments", "fdm_projects(filaments={})"),
    "slicer": Option("--slicer", "fdm_projects(slicers={})"),
    "fdm_layer_height": Option("--layer-height", "FdmSettings(layer_height_mm={})"),
    "nozzle": Option("--nozzle", "FdmSettings(nozzle_mm={})"),
    "bed": Option(None, "FdmSettings(bed_mm={})"),
    "wipe_tower": Option(None, "FdmSettings(wipe_tower_mm={})"),
    "folds": Option("--folds", "calibrate(folds={})"),
}

_OPEN, _SEP, _CLOSE = "\x02", "\x1f", "\x03"
_MARKER = re.compile("\x02([a-z_]+)(?:\x1f([^\x1f\x03]*)\x1f([^\x1f\x03]*))?\x03")


def opt(name: str, value: Any = None, *, cli: str | None = None) -> str:
    """Return a reference to option `name` for the text of a message or a warning.

    The front end that shows the text words it: ``--scale 25.4`` on the command line,
    ``LoadOptions(scale=25.4)`` from Python (:func:`worded`).

    Parameters
    ----------
    name : str
        A key of :data:`OPTIONS`.
    value : object, optional
        The value to show: a string is shown as is on the command line and quoted in
        Python; a tuple is comma-joined on the command line and a tuple in Python;
        a number as it prints.
    cli : str, optional
        What follows the flag on the command line when no `value` is given (``"FILE"``);
        Python then shows ``...``.

    Examples
    --------
    >>> worded(f"pass e.g. {opt('scale', 25.4)}", "cli")
    'pass e.g. --scale 25.4'
    >>> worded(f"pass e.g. {opt('scale', 25.4)}")
    'pass e.g. LoadOptions(scale=25.4)'
    """
    if name not in OPTIONS:
        raise KeyError(f"no option {name!r} in shellvox.errors.OPTIONS")
    if value is None:
        if cli is not None:
            return f"{_OPEN}{name}{_SEP}{cli}{_SEP}{_CLOSE}"
        return f"{_OPEN}{name}{_CLOSE}"
    if isinstance(value, tuple | list):
        cli = ",".join(str(item) for item in value)
        python = repr(tuple(value))
    else:
        cli, python = str(value), repr(value)
    return f"{_OPEN}{name}{_SEP}{cli}{_SEP}{python}{_CLOSE}"


def worded(text: str, front: Front = "python") -> str:
    """Return `text` with each option reference (:func:`opt`) in the words of `front`."""

    def spell(match: re.Match[str]) -> str:
        return OPTIONS[match[1]].spell(front, match[2], match[3])

    return _MARKER.sub(spell, text)


def options_in(text: str) -> tuple[str, ...]:
    """Return the names of the options `text` refers to, in order, each once."""
    return tuple(dict.fromkeys(match[1] for match in _MARKER.finditer(text)))


class InputError(ValueError):
    """Bad user input, reported as one line naming the file, the problem and the fix.

    ``str(error)`` words the options it names for Python (``LoadOptions(repair=True)``);
    the CLI prints ``error.words("cli")`` (``--repair``) on stderr and exits with status 2.

    Parameters
    ----------
    path : str or Path or None
        The file (or option, :func:`opt`) the problem is about.
    problem : str
        What is wrong, with the values seen.
    fix : str
        What the user can do about it.

    Attributes
    ----------
    path, problem, fix : str
        The parts, their options in Python's words (`path` may be None).
    parts : tuple of (str or None, str, str)
        The same with their option references (:func:`opt`), to raise the error again in
        other words.
    options : tuple of str
        The names of the options (keys of :data:`OPTIONS`) the message refers to.
    """

    def __init__(self, path: str | Path | None, problem: str, fix: str) -> None:
        self.parts = (None if path is None else str(path), problem, fix)
        self.path = None if path is None else worded(str(path))
        self.problem = worded(problem)
        self.fix = worded(fix)
        super().__init__(str(self))

    @property
    def options(self) -> tuple[str, ...]:
        """The names of the options the message refers to (keys of :data:`OPTIONS`)."""
        path, problem, fix = self.parts
        return options_in(f"{path or ''} {problem} {fix}")

    def words(self, front: Front = "python") -> str:
        """Return the one-line message with its options in the words of `front`."""
        path, problem, fix = self.parts
        where = f"{path}: " if path else ""
        return worded(f"{where}{problem}; {fix}", front).replace("\n", " ")

    def __str__(self) -> str:
        return self.words("python")


class ShellvoxWarning(UserWarning):
    """Something was changed or assumed on the user's behalf (printed by the CLI).

    Its text may name options (:func:`opt`): ``str(warning)`` words them for Python, the
    command line prints ``warning.words("cli")``.
    """

    def words(self, front: Front = "python") -> str:
        """Return the message with its options in the words of `front`."""
        return worded(str(self.args[0]) if self.args else "", front)

    def __str__(self) -> str:
        return self.words("python")


def _ours(frame: Any) -> bool:
    """Whether `frame` runs code of shellvox (``shellvox`` or one of its subpackages)."""
    name = frame.f_globals.get("__name__", "")
    return bool(name == "shellvox" or name.startswith("shellvox."))


def caller_stacklevel() -> int:
    """Return the ``stacklevel`` that points a warning at the first frame outside shellvox.

    For a :func:`warnings.warn` call in the function that calls this one (level 1): the
    count goes up the stack past every frame of the package (``shellvox`` and its
    subpackages), so a warning points at the user's line however deep inside shellvox
    it was raised.
    """
    frame = sys._getframe(1)  # the caller of caller_stacklevel (the one that warns)
    level = 1
    while frame.f_back is not None and _ours(frame):
        frame = frame.f_back
        level += 1
    return level


def warn(message: str, category: type[Warning] = ShellvoxWarning) -> None:
    """Warn with `message`, attributed to the first line outside shellvox (the user's call).

    Parameters
    ----------
    message : str
        The text; it may name options (:func:`opt`).
    category : type of Warning
        Default :class:`ShellvoxWarning`.
    """
    warnings.warn(category(message), stacklevel=caller_stacklevel())


def add_note(error: BaseException, text: str) -> None:
    """Add the note `text` (it may name options, :func:`opt`) to `error`.

    The note is worded for Python (a traceback shows it as it is); :func:`notes` gives
    it back in the words of another front end.
    """
    shown = worded(text)
    error.add_note(shown)
    error.__dict__.setdefault("_shellvox_notes", {})[shown] = text


def notes(error: BaseException, front: Front = "python") -> list[str]:
    """Return the notes of `error`, each one line, those of :func:`add_note` worded for `front`."""
    raw = error.__dict__.get("_shellvox_notes", {})
    return [
        worded(raw.get(note, note), front).replace("\n", " ")
        for note in getattr(error, "__notes__", ())
    ]


class SlabWorkerDied(RuntimeError):
    """A slab worker process ended without returning its slab (e.g. out of memory).

    Its text may name options (:func:`opt`), worded like :class:`InputError`'s.
    """

    def words(self, front: Front = "python") -> str:
        """Return the message with its options in the words of `front`."""
        return worded(str(self.args[0]) if self.args else "", front)

    def __str__(self) -> str:
        return self.words("python")


class ClusterError(InputError):
    """The Dask scheduler cannot be reached, was lost, or has no workers."""


class OutputBusy(InputError):
    """Another shellvox run holds the output folder (reported like bad input, exit 2)."""


class ResourceError(InputError):
    """The run would not fit the machine (memory, disk, index range); ``--force`` overrides."""


class FdmError(InputError):
    """An FDM project that cannot be made as asked: filaments, colours, depth or slicer."""
