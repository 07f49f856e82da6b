"""The separation tables shipped with the package are what a fresh solve gives.

``scripts/make_tables.py`` writes them; here every shipped profile's default plan reads
its table from the package (no solve), and each file is solved again from its inputs and
compared.
"""

from __future__ import annotations

import numpy as np
import pytest

from shellvox.config import MaterialSettings
from shellvox.printer import DiskTables, build_material_plan, load_profile, shipped_profiles
from shellvox.printer._table_cache import SHIPPED
from shellvox.thickness import DEFAULT_RULE
from shellvox.voxel.colour import _model_separation as solver


class _Recording(DiskTables):
    """The package's tables, recording what is asked and refusing to keep new ones."""

    def save(self, key, table):
        raise AssertionError(f"table {key} was solved: it is not shipped")


@pytest.mark.parametrize("name", shipped_profiles())
def test_every_shipped_profile_finds_its_table_in_the_package(tmp_path, name):
    solver._cached_table.cache_clear()
    layers = DEFAULT_RULE.layers
    plan = build_material_plan(
        load_profile(name),
        MaterialSettings(),
        colour_layers=layers.colour,
        n_bands=layers.n_layers,
        tables=_Recording(tmp_path, SHIPPED),
    )
    assert plan.separation.table.dtype == np.float32


@pytest.mark.slow
def test_the_shipped_tables_are_a_fresh_solve():
    shipped = sorted(SHIPPED.glob("*.npy"))
    assert shipped
    profile = load_profile("j750")
    plan = build_material_plan(profile, MaterialSettings(), colour_layers=(1,), n_bands=2)
    separation = plan.separation
    opaque = separation.roles[:-1] if separation.has_clear else separation.roles
    rows = tuple(profile.optics.roles.index(role) for role in opaque)
    key = solver.table_key(profile.optics, rows, separation.step)
    assert SHIPPED / f"{key}.npy" in shipped
    fresh = solver.solve_model_table(profile.optics, rows, separation.step)
    np.testing.assert_array_equal(np.load(SHIPPED / f"{key}.npy"), fresh)
