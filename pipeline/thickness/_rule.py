"""The thickness rule: how deep each face's colour layer is, from its colour and shape.

The seed paper (Zhu and Chen, *Boundary adjustment algorithm based on element
triangulation*) offsets every triangle by its own distance because colours need colour
layers of different depths, and because upper, lower and side surfaces print differently
and curvature matters. This module holds that rule's numbers, loaded from TOML
(``--thickness-rule FILE``) or :data:`DEFAULT_RULE`. Two rules give the colour layer of a
face before the common limits:

- ``rule = "optical"`` (the default, :mod:`shellvox.thickness._optical_rule`): the depth at
  which the face's mix of materials, over what the build puts beneath it, stops changing
  colour under the printer's two-flux model, to within ``delta_e`` CIEDE2000 (its
  *settling depth*);
- ``rule = "lightness"`` (:mod:`shellvox.thickness._lightness_rule`): a weighted score of
  lightness, chroma and transparency, a judgment kept for comparison.

Then, for both::

    t = t_rule * orientation_factor(n_z)
    t = min(t, max_depth_per_radius / H)          where H > 0 and the cap is on
    t = clip(t, min_mm, max_mm)

and ``t`` is smoothed over ``radius_mm`` of surface
(:func:`shellvox.thickness._surface_smoothing.smooth_over_distance`: area-weighted over the
faces within that distance that face the same side, so independent of the
triangulation), never below the face's own ``t``: the smoothing deepens the faces around
a deeper region, so the depth changes gradually, and never takes from a face the depth
its colour needs. It never leaves ``[min_mm, max_mm]``. Backing layers have constant
thickness.

Defaults of the optical rule (:data:`DEFAULT_RULE`):

- **0.3 to 3.0 mm.** At least 3.5 voxels of the J750's coarsest axis (85 um); at most
  3 mm, where the weakly scattering mixes of transparent colourants (a red of magenta
  and yellow) settle under the assumed optics, while pastels made with white settle
  within a few tenths of a millimetre. A face still changing at 3 mm is flagged.
- **delta_e = 1.0** CIEDE2000: about one just noticeable difference.
- **Orientation** factors 1.0: the two-flux model has no orientation; the factors stay
  available in a rule file (the lightness rule's 1.1 and 1.2 for side and lower faces).
- **Curvature** cap ``0.5 / H`` (below): a depth has to fit the part.
- **Smoothing** over 1 mm of surface.

The lightness rule's defaults are :data:`LIGHTNESS_RULE` (their reasons:
:mod:`shellvox.thickness._lightness_rule`). Common to both:

- **Curvature**: a colour layer at most ``0.5 / H`` deep, half the local radius of convex
  curvature, with ``H`` the mean curvature at a scale of 1 mm (about the colour layer's
  own depth, and independent of the tessellation). An inward offset of
  depth ``d`` shrinks a convex surface's area by about ``2 H d`` and closes at
  ``d = 1 / H``: on a thin rounded feature a full-depth colour layer would leave no room
  for the backing behind it, and colour seen through from the other side mixes in. Half
  the radius leaves room for the backing. Concave regions are not capped. A sharp 90
  degree edge measures about ``pi / (8 r) = 0.39 / mm`` and is not capped (1.27 mm), a
  cube's corner is; a rounded edge of radius 1.5 mm (``H = 1 / 3 mm``) keeps 1.5 mm, a
  sphere of 1.5 mm 0.75 mm.
- **Smoothing** over 1 mm of surface: the depth follows colour regions, not single
  triangles, over the same millimetres however the surface is triangulated.
- **Layers**: one colour layer and one 0.5 mm backing layer.
- **Splitting** (``--max-edge``): faces whose colour spread (p90 CIEDE2000 from their
  median) is 5 or more are split; a CIEDE2000 of about 5 is a clearly visible difference.

The rule file (``--thickness-rule FILE``, TOML) is read by :mod:`shellvox.thickness._rule_file`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError

#: The rules that give a face's colour layer before the common limits.
RuleKind = Literal["optical", "lightness"]

#: Orientation class codes of :func:`orientation_class`.
UPPER, SIDE, LOWER = 0, 1, 2
ORIENTATION_NAMES = ("upper", "side", "lower")


class RuleError(InputError):
    """A rule value out of range: names the key (in place of a file), the problem and the fix.

    Examples
    --------
    >>> str(RuleError("colour_layer.min_mm", "must be a number >= 0, got -1", "write 0.3"))
    'colour_layer.min_mm: must be a number >= 0, got -1; write 0.3'
    """

    def __init__(self, key: str, problem: str, fix: str) -> None:
        super().__init__(key, problem, fix)

    @property
    def key(self) -> str:
        """The rule's key (``table.key``) the problem is about."""
        return self.path or ""


def _require(ok: bool, key: str, problem: str, fix: str) -> None:
    if not ok:
        raise RuleError(key, problem, fix)


def _finite(value: float) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _number(key: str, value: float, *, positive: bool, fix: str) -> None:
    """Refuse a value that is not a finite number ``> 0`` (`positive`) or ``>= 0``."""
    ok = _finite(value) and (value > 0 if positive else value >= 0)
    what = "a positive number" if positive else "a number >= 0"
    _require(ok, key, f"must be {what}, got {value!r}", fix)


@dataclass(frozen=True)
class ColourLayerRule:
    """Range and colour weights of the colour layer (TOML table ``[colour_layer]``).

    Parameters
    ----------
    min_mm, max_mm : float, mm
        Clamp of the colour-layer thickness, ``0 < min_mm <= max_mm``.
    delta_e : float
        The optical rule's CIEDE2000 within which a colour counts as settled, ``> 0``.
    lightness_weight : float
        Weight of ``L* / 100`` (lighter is thicker), ``>= 0``.
    neutral_weight : float
        Weight of ``1 - min(C* / full_chroma, 1)`` (less saturated is thicker), ``>= 0``.
    transparency_weight : float
        Weight of ``1 - alpha`` (more transparent is thicker), ``>= 0``.
    full_chroma : float
        ``C*`` counted as fully saturated, ``> 0``.
    """

    min_mm: float = 0.3
    max_mm: float = 3.0
    delta_e: float = 1.0
    lightness_weight: float = 0.6
    neutral_weight: float = 0.2
    transparency_weight: float = 0.2
    full_chroma: float = 100.0

    def __post_init__(self) -> None:
        for name in ("min_mm", "max_mm", "delta_e", "full_chroma"):
            _number(
                f"colour_layer.{name}", getattr(self, name), positive=True,
                fix=f"set e.g. {name} = {getattr(ColourLayerRule, name)}",
            )  # fmt: skip
        _require(
            self.min_mm <= self.max_mm,
            "colour_layer.min_mm",
            f"is larger than max_mm ({self.min_mm!r} > {self.max_mm!r})",
            "make min_mm <= max_mm",
        )
        weights = ("lightness_weight", "neutral_weight", "transparency_weight")
        for name in weights:
            _number(
                f"colour_layer.{name}", getattr(self, name), positive=False,
                fix=f"set e.g. {name} = {getattr(ColourLayerRule, name)}",
            )  # fmt: skip
        _require(
            sum(getattr(self, name) for name in weights) > 0,
            "colour_layer.lightness_weight",
            "the three colour weights are all 0",
            "give at least one of lightness_weight, neutral_weight, transparency_weight > 0",
        )


@dataclass(frozen=True)
class OrientationRule:
    """Factors per orientation class (TOML table ``[orientation]``).

    Parameters
    ----------
    upper_factor, side_factor, lower_factor : float
        Multipliers of the colour-layer thickness, ``> 0``.
    upper_min_normal_z : float
        A face is *upper* when its unit normal's ``z > upper_min_normal_z``.
    lower_max_normal_z : float
        A face is *lower* when ``z < lower_max_normal_z``; otherwise it is a *side* face.
        ``-1 <= lower_max_normal_z <= upper_min_normal_z <= 1``.
    """

    upper_factor: float = 1.0
    side_factor: float = 1.0
    lower_factor: float = 1.0
    upper_min_normal_z: float = 0.5
    lower_max_normal_z: float = -0.05

    def __post_init__(self) -> None:
        for name in ("upper_factor", "side_factor", "lower_factor"):
            _number(
                f"orientation.{name}", getattr(self, name), positive=True,
                fix=f"set e.g. {name} = 1.0",
            )  # fmt: skip
        lo, hi = self.lower_max_normal_z, self.upper_min_normal_z
        _require(
            _finite(lo) and _finite(hi) and -1 <= lo <= hi <= 1,
            "orientation.lower_max_normal_z",
            f"and upper_min_normal_z must satisfy -1 <= lower <= upper <= 1, got {lo!r}, {hi!r}",
            "set e.g. lower_max_normal_z = -0.05 and upper_min_normal_z = 0.5",
        )


@dataclass(frozen=True)
class CurvatureRule:
    """Curvature cap (TOML table ``[curvature]``).

    Parameters
    ----------
    max_depth_per_radius : float
        The colour layer is at most this fraction of the local convex radius ``1 / H``
        (``>= 0``; 0 turns the cap off and skips the curvature computation).
    radius_mm : float, mm
        Scale ``r`` of the mean curvature ``H``: the local curvature is diffused over
        about this distance (:func:`shellvox.thickness._face_thickness.mean_curvature`; ``> 0``).
    """

    max_depth_per_radius: float = 0.5
    radius_mm: float = 1.0

    def __post_init__(self) -> None:
        _number(
            "curvature.max_depth_per_radius", self.max_depth_per_radius, positive=False,
            fix="set e.g. max_depth_per_radius = 0.5 (0 turns the cap off)",
        )  # fmt: skip
        _require(
            _finite(self.radius_mm) and self.radius_mm > 0,
            "curvature.radius_mm",
            f"must be a positive length in mm, got {self.radius_mm!r}",
            "set e.g. radius_mm = 1.0",
        )


@dataclass(frozen=True)
class SmoothingRule:
    """Averaging over a surface distance (TOML table ``[smoothing]``).

    Parameters
    ----------
    radius_mm : float, mm
        Faces within this distance that face the same side are averaged, area-weighted
        (``>= 0``; 0 turns the smoothing off).
    """

    radius_mm: float = 1.0

    def __post_init__(self) -> None:
        _number(
            "smoothing.radius_mm", self.radius_mm, positive=False,
            fix="set e.g. radius_mm = 1.0 (0 turns the smoothing off)",
        )  # fmt: skip


@dataclass(frozen=True)
class LayersRule:
    """Which shell layers are colour layers and how thick the others are (``[layers]``).

    Parameters
    ----------
    colour : tuple of int
        Shell layers (1-based, outside in) whose thickness follows the colour rule.
    backing_mm : tuple of float, mm
        Thickness of the remaining layers, outside in. ``K = len(colour) + len(backing_mm)``.
    """

    colour: tuple[int, ...] = (1,)
    backing_mm: tuple[float, ...] = (0.5,)

    def __post_init__(self) -> None:
        _require(
            all(_finite(v) and v > 0 for v in self.backing_mm),
            "layers.backing_mm",
            f"must be a list of positive lengths in mm, got {list(self.backing_mm)!r}",
            "set e.g. backing_mm = [0.5]",
        )
        k = self.n_layers
        _require(
            len(self.colour) > 0
            and all(isinstance(v, int) and not isinstance(v, bool) for v in self.colour)
            and all(1 <= v <= k for v in self.colour)
            and len(set(self.colour)) == len(self.colour),
            "layers.colour",
            f"must list distinct layer numbers in 1..{k} (K = len(colour) + "
            f"len(backing_mm)), got {list(self.colour)!r}",
            "set e.g. colour = [1]",
        )

    @property
    def n_layers(self) -> int:
        """``K``, the number of shell layers."""
        return len(self.colour) + len(self.backing_mm)


@dataclass(frozen=True)
class SplitRule:
    """Which faces ``--max-edge`` splits (TOML table ``[split]``).

    Parameters
    ----------
    min_spread_de00 : float
        Faces whose colour spread (p90 CIEDE2000) is at least this are split (``>= 0``; 0
        splits every face with a long edge).
    """

    min_spread_de00: float = 5.0

    def __post_init__(self) -> None:
        _number(
            "split.min_spread_de00", self.min_spread_de00, positive=False,
            fix="set e.g. min_spread_de00 = 5.0",
        )  # fmt: skip


@dataclass(frozen=True)
class ThicknessRule:
    """The whole rule: its kind, colour layer, orientation, curvature, smoothing, layers, split.

    See the module docstring for the formula and the reasons for the defaults; ``rule``
    is a top-level key of the rule file, each part one TOML table.
    """

    rule: RuleKind = "optical"
    colour_layer: ColourLayerRule = field(default_factory=ColourLayerRule)
    orientation: OrientationRule = field(default_factory=OrientationRule)
    curvature: CurvatureRule = field(default_factory=CurvatureRule)
    smoothing: SmoothingRule = field(default_factory=SmoothingRule)
    layers: LayersRule = field(default_factory=LayersRule)
    split: SplitRule = field(default_factory=SplitRule)

    def __post_init__(self) -> None:
        _require(
            self.rule in get_args(RuleKind),
            "rule",
            f"must be one of {list(get_args(RuleKind))}, got {self.rule!r}",
            'write rule = "optical" or rule = "lightness"',
        )


#: The documented default rule (see the module docstring): the optical rule.
DEFAULT_RULE = ThicknessRule()

#: The lightness rule with its own documented defaults
#: (:mod:`shellvox.thickness._lightness_rule`).
LIGHTNESS_RULE = ThicknessRule(
    rule="lightness",
    colour_layer=ColourLayerRule(max_mm=1.2),
    orientation=OrientationRule(side_factor=1.1, lower_factor=1.2),
)


def orientation_class(normal_z: NDArray[np.float64], rule: OrientationRule) -> NDArray[np.int8]:
    """Return the orientation class of every face.

    Parameters
    ----------
    normal_z : (F,) float64
        ``z`` of the unit outward face normals.
    rule : OrientationRule

    Returns
    -------
    (F,) int8
        :data:`UPPER` (0), :data:`SIDE` (1) or :data:`LOWER` (2).
    """
    classes = np.full(normal_z.shape, SIDE, dtype=np.int8)
    classes[normal_z > rule.upper_min_normal_z] = UPPER
    classes[normal_z < rule.lower_max_normal_z] = LOWER
    return classes


def limited_thickness(
    thickness: NDArray[np.float64],
    normal_z: NDArray[np.float64],
    mean_curvature: NDArray[np.float64],
    rule: ThicknessRule,
) -> NDArray[np.float64]:
    """Apply the common limits to a rule's colour layer (see the module).

    The orientation factor, the curvature cap, then the clamp to ``[min_mm, max_mm]``.

    Parameters
    ----------
    thickness : (F,) float64, mm
        The rule's colour layer per face.
    normal_z : (F,) float64
        ``z`` of the unit outward normal.
    mean_curvature : (F,) float64, 1/mm
        Mean curvature, positive where convex.
    rule : ThicknessRule

    Returns
    -------
    (F,) float64, mm
        In ``[min_mm, max_mm]``.
    """
    o = rule.orientation
    factor = np.array([o.upper_factor, o.side_factor, o.lower_factor])
    limited = np.asarray(thickness, np.float64) * factor[orientation_class(normal_z, o)]
    cap = rule.curvature.max_depth_per_radius
    if cap > 0:
        convex = mean_curvature > 0
        limited[convex] = np.minimum(limited[convex], cap / mean_curvature[convex])
    clipped: NDArray[np.float64] = np.clip(
        limited, rule.colour_layer.min_mm, rule.colour_layer.max_mm
    )
    return clipped
