"""Several models, one job: the tray file, its layout, parts, plan, mesh and build."""

from __future__ import annotations

from pipeline.tray._build import build_tray
from pipeline.tray._layout import LayoutMode
from pipeline.tray._parts import ThicknessSource
from pipeline.tray._plan import plan_tray
from pipeline.tray._spec import load_tray, tray_from_inputs

__all__ = [
    "LayoutMode",
    "ThicknessSource",
    "build_tray",
    "load_tray",
    "plan_tray",
    "tray_from_inputs",
]
