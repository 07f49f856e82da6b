"""Printers: profiles (TOML, shipped in ``profiles/``), the material plan, cached tables."""

from __future__ import annotations

from pipeline.printer._cgats import CgatsError, Readings, read_cgats, write_cgats
from pipeline.printer._chart import ChartLayout, chart_json, chart_layout, chart_slab
from pipeline.printer._chart_file import chart_readings, read_chart
from pipeline.printer._chart_preview import chart_preview
from pipeline.printer._material_plan import build_material_plan, layer_model
from pipeline.printer._profile import (
    BACKGROUND_KEYS,
    PrinterProfile,
    load_profile,
    parse_profile,
    shipped_profiles,
)
from pipeline.printer._profile_toml import profile_text, profile_with_optics
from pipeline.printer._table_cache import DiskTables

__all__ = [
    "BACKGROUND_KEYS",
    "CgatsError",
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
