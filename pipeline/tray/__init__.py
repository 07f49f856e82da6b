"""Several models, one job: the tray file, its layout, parts, plan, mesh and build."""

from __future__ import annotations

from shellvox.tray._build import build_tray
from shellvox.tray._layout import LayoutMode
from shellvox.tray._parts import ThicknessSource
from shellvox.tray._plan import TrayPlan, plan_tray
from shellvox.tray._spec import load_tray, tray_from_inputs

__all__ = [
    "LayoutMode",
    "ThicknessSource",
    "TrayPlan",
    "build_tray",
    "load_tray",
    "plan_tray",
    "tray_from_inputs",
]
