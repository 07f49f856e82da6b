"""Printers: profiles (TOML, shipped in ``profiles/``), the material plan, cached tables."""
