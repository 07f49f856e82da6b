"""The per-face layer thickness a model gets: constant layers, or a thickness rule.

What ``shellvox thickness``, ``shells``, ``build`` and ``fdm`` do with ``--thickness``,
``--thickness-rule`` and ``--max-edge``: :func:`layer_thickness`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.config import MaterialSettings
from shellvox.errors import InputError, opt
from shellvox.model import ColouredMesh
from shellvox.printer import PrinterProfile, build_material_plan, layer_model, load_profile
from shellvox.thickness import (
    DEFAULT_RULE,
    FaceThickness,
    ThicknessRule,
    face_colour,
    face_thickness,
    load_rule,
    split_for_thickness,
)


@dataclass(frozen=True, eq=False)
class ThicknessChoice:
    """The thickness of each layer on each face, and the mesh it applies to.

    Attributes
    ----------
    mesh : ColouredMesh
        The model, split where its faces' colour varies when `max_edge_mm` asked for it.
    thickness_mm : (K, F) float64, mm
        Thickness of each of the ``K`` layers (outside in) on each face.
    faces : FaceThickness or None
        The rule's result, with what decided each face (None for constant layers).
    source : str
        ``"--thickness"`` (constant layers), ``"default rule"`` or the rule file's path.
    """

    mesh: ColouredMesh
    thickness_mm: NDArray[np.float64]
    faces: FaceThickness | None
    source: str

    def __repr__(self) -> str:
        """One line: the layers, the faces, the outer layer's range and the source."""
        layers, faces = self.thickness_mm.shape
        outer = self.thickness_mm[0] if layers and faces else np.zeros(1)
        return (
            f"ThicknessChoice({layers} layers on {faces} faces, layer 1 "
            f"{outer.min():.3g}-{outer.max():.3g} mm, source={self.source!r})"
        )


def layer_thickness(
    mesh: ColouredMesh,
    *,
    thickness_mm: Sequence[float] | None = None,
    rule: ThicknessRule | str | Path | None = None,
    max_edge_mm: float | None = None,
    printer: str | Path | PrinterProfile = "j750",
    materials: MaterialSettings | None = None,
    max_faces: int = 5_000_000,
) -> ThicknessChoice:
    """Return each face's layer thickness: `thickness_mm` on every face, or a rule's.

    Parameters
    ----------
    mesh : ColouredMesh
        The model (:func:`shellvox.load_model`).
    thickness_mm : sequence of float, mm, optional
        The same thickness of each layer, outside in, on every face (``--thickness``).
        Not together with `rule` or `max_edge_mm`.
    rule : ThicknessRule or path, optional
        A thickness rule or its TOML file (``--thickness-rule``); default: the built-in
        optical rule (each face's colour layer as deep as its colour needs to settle
        under the printer's optics).
    max_edge_mm : float, mm, optional
        First split the faces whose colour varies until no edge is longer (``--max-edge``),
        so the thickness can follow a texture.
    printer : str, path or PrinterProfile
        The printer whose optics the optical rule uses (a shipped name or a TOML file).
    materials : MaterialSettings, optional
        The separation the optical rule predicts with (default: the profile's materials).
    max_faces : int
        Most faces the split may make.

    Returns
    -------
    ThicknessChoice

    Raises
    ------
    InputError
        Constant layers together with a rule or a split; a bad length; a bad rule file.

    Examples
    --------
    >>> import shellvox
    >>> mesh = shellvox.load_model(shellvox.data.colour_target())
    >>> choice = shellvox.layer_thickness(mesh, thickness_mm=(0.5, 0.3))
    >>> choice.thickness_mm.shape == (2, mesh.n_faces), choice.source
    (True, '--thickness')
    >>> ruled = shellvox.layer_thickness(mesh)  # the optical rule
    >>> bool(ruled.thickness_mm[0].min() < ruled.thickness_mm[0].max())
    True
    """
    if thickness_mm is not None:
        for option, value in (("thickness_rule", rule), ("max_edge", max_edge_mm)):
            if value is not None:
                raise InputError(
                    opt(option),
                    f"cannot be combined with {opt('thickness')} (the same thickness on every "
                    "face)",
                    f"drop {opt('thickness')} to use a thickness rule, or drop {opt(option)}",
                )
        constant = np.asarray(thickness_mm, np.float64)
        if (
            constant.ndim != 1
            or not len(constant)
            or not np.all(np.isfinite(constant) & (constant > 0))
        ):
            raise InputError(
                opt("thickness"),
                f"expected positive lengths, got {list(np.atleast_1d(constant))}",
                f"pass lengths in mm such as {opt('thickness', (0.5, 0.5))}",
            )
        rows = np.repeat(constant[:, None], mesh.n_faces, axis=1)
        return ThicknessChoice(mesh, rows, None, "--thickness")
    if rule is None:
        chosen, source = DEFAULT_RULE, "default rule"
    elif isinstance(rule, ThicknessRule):
        chosen, source = rule, "given rule"
    else:
        chosen, source = load_rule(Path(rule)), str(rule)
    profile = printer if isinstance(printer, PrinterProfile) else load_profile(printer)
    colour = None
    if max_edge_mm is not None:
        if not (np.isfinite(max_edge_mm) and max_edge_mm > 0):
            raise InputError(
                opt("max_edge"),
                f"expected a positive length, got {max_edge_mm}",
                f"pass e.g. {opt('max_edge', 0.5)}",
            )
        colour = face_colour(mesh)
        split = split_for_thickness(mesh, chosen, max_edge_mm, colour=colour, max_faces=max_faces)
        if split is not mesh:
            mesh, colour = split, None
    model = None
    if chosen.rule == "optical":
        layers = chosen.layers
        plan = build_material_plan(
            profile,
            materials or MaterialSettings(),
            colour_layers=layers.colour,
            n_bands=layers.n_layers,
        )
        model = layer_model(profile, plan, layers.backing_mm)
    faces = face_thickness(mesh, chosen, colour=colour, model=model)
    return ThicknessChoice(mesh, faces.thickness_mm, faces, source)
