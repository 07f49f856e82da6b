"""Printers: profiles (TOML, shipped in ``profiles/``), the material plan, cached tables."""

from __future__ import annotations

from shellvox.printer._cgats import CgatsError, Readings, read_cgats, write_cgats
from shellvox.printer._chart import ChartLayout, chart_json, chart_layout, chart_slab
from shellvox.printer._chart_file import ChartFile, chart_readings, read_chart
from shellvox.printer._chart_preview import chart_preview
from shellvox.printer._material_plan import build_material_plan, layer_model
from shellvox.printer._profile import (
    BACKGROUND_KEYS,
    PrinterProfile,
    load_profile,
    parse_profile,
    shipped_profiles,
)
from shellvox.printer._profile_toml import profile_text, profile_with_optics
from shellvox.printer._table_cache import DiskTables

__all__ = [
    "BACKGROUND_KEYS",
    "CgatsError",
    "ChartFile",
    "ChartLayout",
    "DiskTables",
    "PrinterProfile",
    "Readings",
    "build_material_plan",
    "chart_json",
    "chart_layout",
    "chart_preview",
    "chart_readings",
    "chart_slab",
    "layer_model",
    "load_profile",
    "parse_profile",
    "profile_text",
    "profile_with_optics",
    "read_cgats",
    "read_chart",
    "shipped_profiles",
    "write_cgats",
]
