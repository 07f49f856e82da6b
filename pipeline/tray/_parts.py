"""A tray's distinct models, each prepared alone: scaled, turned, its layers and its grid.

:func:`prepare_part` reads nothing: it takes a loaded model and the tray entry, and finds
the layer count and an upper bound of the deepest layer without computing any thickness
rule (a rule's colour layers are at most its clamp, its backing layers constant).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from shellvox.config import BuildConfig
from shellvox.errors import InputError, opt
from shellvox.model import ColouredMesh, face_areas
from shellvox.stack import grid_for
from shellvox.thickness import ThicknessRule, load_rule
from shellvox.tray._spec import TrayModel
from shellvox.voxel.grid import GridSpec


@dataclass(frozen=True)
class ThicknessSource:
    """Where a tray model's thickness comes from (the command line's unless it says).

    Attributes
    ----------
    constant_mm : tuple of float, optional
        The same thickness per layer on every face (``thickness`` / ``--thickness``).
    rule_path : Path, optional
        The rule file (``thickness_rule`` / ``--thickness-rule``); neither: the default
        rule.
    """

    constant_mm: tuple[float, ...] | None = None
    rule_path: Path | None = None

    def describe(self) -> str:
        """``"--thickness 0.5,0.5"``-like text for messages and the manifest."""
        if self.constant_mm is not None:
            return "thickness " + ",".join(f"{t:g}" for t in self.constant_mm)
        return "default rule" if self.rule_path is None else f"rule {self.rule_path}"


@dataclass(frozen=True, eq=False)
class TrayPart:
    """A distinct model of a tray in its own coordinates (its copies share it).

    Attributes
    ----------
    spec : TrayModel
        The tray entry.
    mesh : ColouredMesh
        The model, scaled and turned, not moved.
    thickness : ThicknessSource
        Where its thickness comes from.
    rule : ThicknessRule or None
        Its rule (None for a constant thickness).
    n_layers : int
        Layers ``K``.
    colour_layers : tuple of int
        Layers taking the surface colour.
    reach_mm : float, mm
        Upper bound of its deepest layer, or the level-set half width if larger.
    area_mm2 : float, mm^2
        Surface area.
    grid : GridSpec
        Its own grid (as a build of it alone).
    """

    spec: TrayModel
    mesh: ColouredMesh
    thickness: ThicknessSource
    rule: ThicknessRule | None
    n_layers: int
    colour_layers: tuple[int, ...]
    reach_mm: float
    area_mm2: float
    grid: GridSpec


def prepare_part(
    model: TrayModel,
    mesh: ColouredMesh,
    rules: dict[Path | None, ThicknessRule],
    config: BuildConfig,
    default: ThicknessSource,
    colour_layers: tuple[int, ...] | None,
) -> TrayPart:
    """Return a tray entry's model, scaled and turned, with its layers and grid."""
    factor = model.scale
    if model.size_mm is not None:  # the loaded mesh has only used vertices: its extent
        factor = model.size_mm / float(np.ptp(mesh.vertices, axis=0).max())
    if factor != 1.0 or any(model.rotation_deg):
        turn = Rotation.from_euler("xyz", model.rotation_deg, degrees=True).as_matrix()
        mesh = dataclasses.replace(mesh, vertices=(mesh.vertices * factor) @ turn.T)
    if model.thickness_mm is not None:
        source = ThicknessSource(constant_mm=model.thickness_mm)
    elif model.thickness_rule is not None:
        source = ThicknessSource(rule_path=model.thickness_rule)
    else:
        source = default
    rule = None
    if source.constant_mm is not None:
        n_layers = len(source.constant_mm)
        colour = colour_layers or (1,)
        depth = sum(source.constant_mm)
    else:
        if source.rule_path not in rules:
            assert source.rule_path is not None
            rules[source.rule_path] = load_rule(source.rule_path)
        rule = rules[source.rule_path]
        n_layers = rule.layers.n_layers
        colour = colour_layers or tuple(rule.layers.colour)
        depth = len(rule.layers.colour) * rule.colour_layer.max_mm + sum(rule.layers.backing_mm)
    return TrayPart(
        spec=model,
        mesh=mesh,
        thickness=source,
        rule=rule,
        n_layers=n_layers,
        colour_layers=colour,
        reach_mm=max(depth, config.sdf_half_width_mm),
        area_mm2=float(face_areas(mesh.vertices, mesh.faces).sum()),
        grid=grid_for(mesh, config),
    )


def check_same_layers(parts: list[TrayPart], source: str) -> None:
    """Refuse models with different layer counts or colour layers (one stack needs one)."""
    first = parts[0]
    for part in parts[1:]:
        if part.n_layers != first.n_layers:
            raise InputError(
                source,
                f"{part.spec.name} has {part.n_layers} layers ({part.thickness.describe()}) "
                f"but {first.spec.name} has {first.n_layers} ({first.thickness.describe()})",
                "give every model the same number of layers (each its own thicknesses)",
            )
        if part.colour_layers != first.colour_layers:
            raise InputError(
                source,
                f"{part.spec.name} colours layers {list(part.colour_layers)} but "
                f"{first.spec.name} colours {list(first.colour_layers)}",
                f"use rules with the same colour layers, or pass {opt('colour_layers')}",
            )


def extent(mesh: ColouredMesh) -> NDArray[np.float64]:
    """Size ``(3,) float64`` mm of a mesh's bounding box."""
    extent: NDArray[np.float64] = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    return extent
