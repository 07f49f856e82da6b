"""The separation tables shipped with the package are what a fresh solve gives.

``scripts/make_tables.py`` writes them; here every shipped profile's default plan reads
its table from the package (no solve), and each file is solved again from its inputs and
compared by what a build depends on, which holds on any processor: the colour each mix
predicts, and the solver's criterion (least cost, CIEDE2000 squared plus the grain
tie-break), not the bits, which differ in the last places between processors. A solve
with the vector instructions and BLAS kernels of another processor (numpy's dispatch
switched off, OpenBLAS's core set) is held to the same bounds.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import colour
import numpy as np
import pytest

from shellvox.config import MaterialSettings
from shellvox.printer import DiskTables, build_material_plan, load_profile, shipped_profiles
from shellvox.printer._table_cache import SHIPPED
from shellvox.thickness import DEFAULT_RULE
from shellvox.voxel.colour import DeepColour, invert, observer, srgb_to_lab_d50
from shellvox.voxel.colour import _model_separation as solver
from shellvox.voxel.colour._inversion import GRAIN_WEIGHT
from shellvox.voxel.colour._separation import node_codes

#: Two solves of one table agree within this CIEDE2000 between their mixes' colours at
#: every node (they differ where the descent stops short in a flat valley; measured up to
#: 0.39 between this machine's own and its baseline instructions with OpenBLAS's oldest
#: kernels)...
COLOUR_TOLERANCE = 1.0

#: ... and neither's mix is better than the other's by more than this in the solver's
#: cost (CIEDE2000 squared plus the grain term), nor, at equal colour error within it,
#: has less grain (the tie-break); measured up to 0.39.
COST_TOLERANCE = 1.0


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


def _j750_rows():
    profile = load_profile("j750")
    plan = build_material_plan(profile, MaterialSettings(), colour_layers=(1,), n_bands=2)
    separation = plan.separation
    opaque = separation.roles[:-1] if separation.has_clear else separation.roles
    rows = tuple(profile.optics.roles.index(role) for role in opaque)
    return profile, rows, separation.step


def _targets(step, white_xy):
    codes = node_codes(step)
    grid = np.stack(np.meshgrid(codes, codes, codes, indexing="ij"), -1).reshape(-1, 3)
    return srgb_to_lab_d50(grid / 255.0, white_xy)


def _assert_same_choice(deep, target, one, other):
    """Both mixes `(N, P)` for `target` `(N, 3)` are the solver's choice within the bounds."""
    lab_one, lab_other = deep(one), deep(other)
    apart = colour.delta_E(lab_one, lab_other, method="CIE 2000")
    assert apart.max() <= COLOUR_TOLERANCE, (
        f"{(apart > COLOUR_TOLERANCE).sum()} of {len(apart)} nodes differ in colour, "
        f"up to dE00 {apart.max():.3f}"
    )
    pure = deep(np.eye(one.shape[1]))
    grain = ((pure[None] - target[:, None]) ** 2).sum(-1)
    error = [colour.delta_E(lab, target, method="CIE 2000") ** 2 for lab in (lab_one, lab_other)]
    ink = [GRAIN_WEIGHT * (p * grain).sum(-1) for p in (one, other)]
    cost = [e + g for e, g in zip(error, ink, strict=True)]
    assert np.abs(cost[0] - cost[1]).max() <= COST_TOLERANCE
    tied = np.abs(error[0] - error[1]) <= COST_TOLERANCE
    assert np.abs(ink[0] - ink[1])[tied].max(initial=0.0) <= COST_TOLERANCE


@pytest.mark.slow
def test_the_shipped_tables_are_a_fresh_solve():
    shipped = sorted(SHIPPED.glob("*.npy"))
    assert shipped
    profile, rows, step = _j750_rows()
    key = solver.table_key(profile.optics, rows, step)
    assert SHIPPED / f"{key}.npy" in shipped
    fresh = solver.solve_model_table(profile.optics, rows, step)
    table = np.load(SHIPPED / f"{key}.npy")
    assert table.shape == fresh.shape and table.dtype == fresh.dtype == np.float32
    deep = DeepColour(profile.optics, rows)
    target = _targets(step, observer(profile.optics.wavelengths_nm).white_xy)
    n = fresh.shape[-1]
    _assert_same_choice(
        deep, target, table.reshape(-1, n).astype(np.float64), fresh.reshape(-1, n).astype(float)
    )


_OTHER_PROCESSOR = """
import sys
import numpy as np
from shellvox.printer import load_profile
from shellvox.voxel.colour import DeepColour, invert
rows = tuple(int(r) for r in sys.argv[3].split(","))
deep = DeepColour(load_profile("j750").optics, rows)
np.save(sys.argv[2], invert(deep, np.load(sys.argv[1])).proportions)
"""


@pytest.mark.slow
def test_a_solve_with_another_processors_instructions_makes_the_same_choices(tmp_path):
    from numpy._core import _multiarray_umath as umath

    dispatched = [f for f in umath.__cpu_dispatch__ if umath.__cpu_features__.get(f)]
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(dispatched))
    if platform.machine() in ("x86_64", "AMD64"):
        env["OPENBLAS_CORETYPE"] = "Prescott"  # the oldest kernels: other sums, no FMA
    profile, rows, _ = _j750_rows()
    target = _targets(15, observer(profile.optics.wavelengths_nm).white_xy)
    np.save(tmp_path / "target.npy", target)
    args = [str(tmp_path / "target.npy"), str(tmp_path / "found.npy"), ",".join(map(str, rows))]
    subprocess.run([sys.executable, "-c", _OTHER_PROCESSOR, *args], env=env, check=True)
    deep = DeepColour(profile.optics, rows)
    here = invert(deep, target).proportions
    _assert_same_choice(deep, target, here, np.load(tmp_path / "found.npy"))
