"""Per-face layer thickness: face colours, the rule, its file, splitting faces.

- :mod:`~shellvox.thickness._face_colour` a robust CIELAB colour per face, with its spread;
- :mod:`~shellvox.thickness._rule` the thickness rule and its defaults;
- :mod:`~shellvox.thickness._rule_file` rules from TOML files;
- :mod:`~shellvox.thickness._face_thickness` the rule applied: thickness per face and layer;
- :mod:`~shellvox.thickness._face_split` faces split so the thickness can follow a texture.

Nothing here writes files (the thickness PLY is :func:`shellvox.output._ply.write_thickness_ply`).
"""

from __future__ import annotations

from shellvox.thickness._face_colour import FaceColour, face_colour, face_samples
from shellvox.thickness._face_split import split_faces, split_for_thickness
from shellvox.thickness._face_thickness import (
    FaceThickness,
    face_thickness,
    mean_curvature,
    thickness_summary,
)
from shellvox.thickness._optical_rule import OpticalFaces, optical_thickness
from shellvox.thickness._rule import (
    DEFAULT_RULE,
    LIGHTNESS_RULE,
    ColourLayerRule,
    CurvatureRule,
    LayersRule,
    SmoothingRule,
    SplitRule,
    ThicknessRule,
)
from shellvox.thickness._rule_file import load_rule
from shellvox.thickness._surface_smoothing import smooth_over_distance

__all__ = [
    "DEFAULT_RULE",
    "LIGHTNESS_RULE",
    "ColourLayerRule",
    "CurvatureRule",
    "FaceColour",
    "FaceThickness",
    "LayersRule",
    "OpticalFaces",
    "SmoothingRule",
    "SplitRule",
    "ThicknessRule",
    "face_colour",
    "face_samples",
    "face_thickness",
    "load_rule",
    "mean_curvature",
    "optical_thickness",
    "smooth_over_distance",
    "split_faces",
    "split_for_thickness",
    "thickness_summary",
]
