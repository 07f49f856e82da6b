"""A build tray: several models, each with its placement and thickness, in one job.

A tray comes from ``shellvox build a.glb b.ply ... [--copies N]`` (:func:`tray_from_inputs`)
or from a TOML file (``--tray tray.toml``, :func:`load_tray`), one ``[[model]]`` table per
model::

    [[model]]
    file = "spot.obj"  # relative to the tray file's folder
    position = [10, 20]  # x, y[, z] mm of the model's bounding-box minimum
    rotation = [0, 0, 90]  # degrees about the tray's x, then y, then z axis
    scale = 60  # times the loader's millimetres (and --scale or --size)
    # or: size = 50  # mm: the longest side, scaled to it (a slicer's scale-to-fit)
    thickness_rule = "rule.toml"  # or thickness = [0.5, 0.5] (mm per layer)
    copies = 2  # placed by --layout auto

Rotation convention: extrinsic x-y-z Euler angles in degrees (scipy's ``"xyz"``): the
model is scaled (``scale``, or ``size`` on its loaded bounding box), then turned about
the tray's fixed x axis, then y, then z, and then moved so that its bounding-box
minimum lies at ``position`` (``z`` default 0: on the tray). Printer, layers, materials
and voxel size stay on the command line.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shellvox.errors import InputError, opt

#: Keys of a ``[[model]]`` table.
MODEL_KEYS = (
    "file",
    "position",
    "rotation",
    "scale",
    "size",
    "thickness",
    "thickness_rule",
    "copies",
)


@dataclass(frozen=True)
class TrayModel:
    """One model of a tray and how it is placed.

    Parameters
    ----------
    file : Path
        Model file.
    position_mm : (3,) float, mm, optional
        Where the model's bounding-box minimum ``(x, y, z)`` goes on the tray (None: the
        layout chooses).
    rotation_deg : (3,) float, degrees
        Extrinsic rotations about the tray's x, y and z axes, in that order.
    scale : float
        Factor on the loaded millimetres.
    size_mm : float, mm, optional
        The longest side of the model's bounding box, scaled to it uniformly before the
        rotation (instead of `scale`).
    thickness_mm : tuple of float, mm, optional
        The same thickness per layer on every face (outside in).
    thickness_rule : Path, optional
        Rule file of the per-face thickness. Neither this nor `thickness_mm`: the
        command line's thickness options.
    copies : int
        Copies of the model (only the first can take `position_mm`).
    """

    file: Path
    position_mm: tuple[float, float, float] | None = None
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float = 1.0
    size_mm: float | None = None
    thickness_mm: tuple[float, ...] | None = None
    thickness_rule: Path | None = None
    copies: int = 1

    @property
    def name(self) -> str:
        """The model's name in messages (its file name)."""
        return self.file.name


@dataclass(frozen=True)
class TraySpec:
    """The models of a tray and where they came from.

    Parameters
    ----------
    models : tuple of TrayModel
        At least one.
    source : str
        The tray file, or ``""`` for models given on the command line.
    """

    models: tuple[TrayModel, ...]
    source: str = ""

    @property
    def n_instances(self) -> int:
        """Models on the tray, copies counted."""
        return sum(model.copies for model in self.models)


def tray_from_inputs(files: list[Path], copies: int = 1) -> TraySpec:
    """Return the tray of model files given on the command line, ``copies`` of each."""
    if copies < 1:
        raise InputError(opt("copies"), f"got {copies}", "give 1 or more copies of each model")
    return TraySpec(tuple(TrayModel(Path(f), copies=copies) for f in files))


def load_tray(path: str | Path) -> TraySpec:
    """Read a tray file (see the module); relative paths are from its folder.

    Raises
    ------
    InputError
        The file is missing or not TOML, or an entry is bad; the message names the file,
        the entry (``model[i]``, counting from 1) and the fix.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise InputError(
            path, f"cannot be read ({error.strerror})", "check the path of the tray file"
        ) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise InputError(path, f"is not valid TOML ({error})", "fix the syntax") from None
    unknown = sorted(set(data) - {"model"})
    if unknown:
        raise InputError(path, f"unknown top-level key(s) {unknown}", "give [[model]] tables only")
    entries = data.get("model")
    if not isinstance(entries, list) or not entries:
        raise InputError(path, "holds no [[model]] table", 'add [[model]] with file = "..."')
    return TraySpec(tuple(_model(path, i + 1, entry) for i, entry in enumerate(entries)), str(path))


def _model(path: Path, number: int, entry: dict[str, Any]) -> TrayModel:
    """Return the ``number``-th ``[[model]]`` table of a tray file, checked."""
    where = f"{path}: model[{number}]"

    def bad(key: str, problem: str, fix: str) -> InputError:
        return InputError(f"{where}.{key}", problem, fix)

    unknown = sorted(set(entry) - set(MODEL_KEYS))
    if unknown:
        raise InputError(where, f"unknown key(s) {unknown}", f"use only {', '.join(MODEL_KEYS)}")
    file = entry.get("file")
    if not isinstance(file, str) or not file:
        raise bad("file", f"expected a file name, got {file!r}", 'set file = "model.glb"')
    position = entry.get("position")
    if position is not None:
        values = _numbers(position)
        if values is None or len(values) not in (2, 3):
            raise bad(
                "position",
                f"expected [x, y] or [x, y, z] in mm, got {position!r}",
                "set e.g. position = [10, 20]",
            )
        position = (values[0], values[1], values[2] if len(values) == 3 else 0.0)
    rotation = entry.get("rotation", [0, 0, 0])
    angles = _numbers(rotation)
    if angles is None or len(angles) != 3:
        raise bad(
            "rotation",
            f"expected [x, y, z] in degrees, got {rotation!r}",
            "set e.g. rotation = [0, 0, 90]",
        )
    scale = entry.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not 0 < scale < math.inf:
        raise bad("scale", f"expected a positive number, got {scale!r}", "set e.g. scale = 1.5")
    size = entry.get("size")
    if size is not None and (
        isinstance(size, bool) or not isinstance(size, int | float) or not 0 < size < math.inf
    ):
        raise bad("size", f"expected a positive length in mm, got {size!r}", "set e.g. size = 50")
    if size is not None and "scale" in entry:
        raise InputError(where, "gives both scale and size", "keep one of them")
    thickness = entry.get("thickness")
    rule = entry.get("thickness_rule")
    if thickness is not None and rule is not None:
        raise InputError(where, "gives both thickness and thickness_rule", "keep one of them")
    if thickness is not None:
        layers = _numbers(thickness)
        if not layers or not all(t > 0 for t in layers):
            raise bad(
                "thickness",
                f"expected positive mm per layer, got {thickness!r}",
                "set e.g. thickness = [0.5, 0.5]",
            )
        thickness = tuple(layers)
    if rule is not None and (not isinstance(rule, str) or not rule):
        raise bad(
            "thickness_rule",
            f"expected a rule file name, got {rule!r}",
            'set e.g. thickness_rule = "rule.toml"',
        )
    copies = entry.get("copies", 1)
    if isinstance(copies, bool) or not isinstance(copies, int) or copies < 1:
        raise bad("copies", f"expected a whole number >= 1, got {copies!r}", "set copies = 1")
    if copies > 1 and position is not None:
        raise InputError(
            where,
            f"gives a position and copies = {copies}",
            "give each copy its own [[model]] with a position, or drop the "
            f"position and use {opt('layout', 'auto')}",
        )
    folder = path.parent
    return TrayModel(
        file=folder / file,
        position_mm=position,
        rotation_deg=(angles[0], angles[1], angles[2]),
        scale=float(scale),
        size_mm=None if size is None else float(size),
        thickness_mm=thickness,
        thickness_rule=None if rule is None else folder / rule,
        copies=copies,
    )


def _numbers(value: object) -> list[float] | None:
    """Return a list of finite numbers, or None when `value` is not one."""
    if not isinstance(value, list):
        return None
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
        return None
    numbers = [float(v) for v in value]
    return numbers if all(math.isfinite(v) for v in numbers) else None
