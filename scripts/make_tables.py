"""Solve the separation tables of the shipped printer profiles into the package.

Every table a build with a shipped profile and the default material settings needs
(its separation, the optical thickness rule's) is solved afresh and written to
``pipeline/printer/tables/<key>.npy``; the key names the inputs (materials' optics, table
step, solver version). Another processor solves the same mixes but for the last places
where the descent stops short (within a fraction of a CIEDE2000 unit), so a re-solve
elsewhere need not be shipped. Run it after a change of a shipped profile's materials or
optics, or of the solver; ``tests/printer/test_shipped_tables.py`` checks the files
against a fresh solve by colour and by the solver's criterion. One solve takes about a
minute of one core.

    .venv/bin/python scripts/make_tables.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from shellvox.config import MaterialSettings
from shellvox.printer import DiskTables, build_material_plan, load_profile, shipped_profiles
from shellvox.thickness import DEFAULT_RULE
from shellvox.voxel.colour import _model_separation as solver

OUT = Path(__file__).resolve().parents[1] / "pipeline" / "printer" / "tables"


def main() -> int:
    """Solve and write the tables; return the exit status."""
    store = DiskTables(OUT)  # no shipped folder: every table is solved here
    for path in OUT.glob("*.npy"):
        path.unlink()
    solver._cached_table.cache_clear()
    layers = DEFAULT_RULE.layers
    for name in shipped_profiles():
        profile = load_profile(name)
        for colour, bands in ((layers.colour, layers.n_layers), ((1,), 2)):
            build_material_plan(
                profile, MaterialSettings(), colour_layers=colour, n_bands=bands, tables=store
            )
        print(name, sorted(p.name for p in OUT.glob("*.npy")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
