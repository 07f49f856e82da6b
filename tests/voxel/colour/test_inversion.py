"""Separation by inverting the two-flux model, against slow references."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.optimize import minimize

from shellvox.voxel.colour import (
    DeepColour,
    assumed_optics,
    body_reflectance,
    display_reflectance,
    invert,
    observer,
    project_to_simplex,
    saunderson,
    srgb_to_lab_d50,
)

NAMES = ("VeroCyan", "VeroMagenta", "VeroYellow", "VeroBlack", "VeroWhite", "VeroClear")
ROLES = ("cyan", "magenta", "yellow", "black", "white", "clear")
DISPLAY = [[0, 89, 158], [161, 35, 99], [213, 178, 0], [30, 30, 30], [220, 222, 216],
           [255, 255, 255]]  # fmt: skip


@pytest.fixture(scope="module")
def deep():
    return DeepColour(assumed_optics(NAMES, ROLES, DISPLAY), range(5))


def test_saunderson_inverted():
    body = np.linspace(1e-3, 0.999, 50)
    assert body_reflectance(saunderson(body, 0.04, 0.6), 0.04, 0.6) == pytest.approx(body)


def test_assumed_optics_give_a_deep_patch_its_display_reflectance():
    optics = assumed_optics(NAMES, ROLES, DISPLAY)
    assert optics.assumed
    measured = display_reflectance(DISPLAY, optics.wavelengths_nm)
    deep = DeepColour(optics, range(6))
    seen = observer(optics.wavelengths_nm)
    from shellvox.voxel.colour import r_infinity

    body = r_infinity(optics.k_per_mm, optics.s_per_mm)
    shown = saunderson(body, optics.k1, optics.k2, specular_included=False)
    above = measured > optics.k1 + 0.01  # bands the surface reflection does not hide
    assert shown[:5][above[:5]] == pytest.approx(measured[:5][above[:5]], rel=1e-9)
    # with the gloss included, the deep white is lighter by the surface's k1
    from shellvox.voxel.colour import reflectance_to_lab

    glossy = reflectance_to_lab(measured[4] + optics.k1, seen)
    assert colour.delta_E(deep(np.eye(6)[4]), glossy, method="CIE 2000") < 0.01


def test_projection_onto_the_simplex_is_the_nearest_point():
    rng = np.random.default_rng(3)
    v = rng.normal(0, 1, (30, 5))
    p = project_to_simplex(v)
    assert p.min() >= 0 and p.sum(1) == pytest.approx(1.0)
    for row, got in zip(v, p, strict=True):
        ref = minimize(
            lambda q, row=row: ((q - row) ** 2).sum(),
            np.full(5, 0.2),
            bounds=[(0, 1)] * 5,
            constraints=[{"type": "eq", "fun": lambda q: q.sum() - 1}],
            method="SLSQP",
            options={"ftol": 1e-14},
        )
        assert got == pytest.approx(ref.x, abs=1e-6)


def test_in_gamut_targets_are_matched(deep):
    rng = np.random.default_rng(4)
    truth = rng.dirichlet(np.full(5, 0.5), 500)
    found = invert(deep, deep(truth))
    assert found.proportions.min() >= 0
    assert found.proportions.sum(1) == pytest.approx(1.0)
    assert found.lab == pytest.approx(deep(found.proportions))
    assert np.median(found.delta_e) < 0.05 and np.percentile(found.delta_e, 95) < 0.2


def _slow_minimum(deep, lab):
    """Nelder-Mead on the simplex (shares as |q| / sum |q|) from the nearest material."""

    def cost(q):
        shares = np.abs(q) / np.abs(q).sum()
        return float(colour.delta_E(deep(shares), lab, method="CIE 2000")) ** 2

    nearest = np.argmin(colour.delta_E(deep(np.eye(5)), lab, method="CIE 2000"))
    best = minimize(cost, np.eye(5)[nearest] + 0.01, method="Nelder-Mead",
                    options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000})  # fmt: skip
    return np.sqrt(best.fun)


def test_no_worse_than_a_slow_optimiser_or_brute_force(deep):
    rng = np.random.default_rng(5)
    target = srgb_to_lab_d50(rng.uniform(0, 1, (6, 3)), observer().white_xy)
    found = invert(deep, target)
    brute_lab = deep(rng.dirichlet(np.full(5, 0.3), 20000))
    for lab, de in zip(target, found.delta_e, strict=True):
        # out of gamut the minimum lies on the boundary: within 0.1 of the references'
        assert de <= colour.delta_E(brute_lab, lab, method="CIE 2000").min() + 0.1
        assert de <= _slow_minimum(deep, lab) + 0.1


def test_starts_that_tie_within_the_quantum_go_to_the_lowest_grid_row(deep):
    """Costs equal but for float noise pick one start: the least row among the k nearest."""
    from shellvox.voxel.colour._inversion import (
        COST_QUANTUM,
        LOG_SHARES,
        START_CANDIDATES,
        START_DIVISIONS,
        _start,
        cost_rank,
        log_grid,
        simplex_grid,
    )

    grid = np.concatenate(
        [simplex_grid(5, START_DIVISIONS)]
        + [np.roll(log_grid(5, LOG_SHARES), b, axis=1) for b in range(5)]
    )
    grid_lab = deep(grid)
    rng = np.random.default_rng(6)
    target = srgb_to_lab_d50(rng.uniform(0, 1, (40, 3)), observer().white_xy)
    distance = ((grid_lab[None] - target[:, None]) ** 2).sum(-1)
    nearest = np.argsort(distance, axis=1, kind="stable")[:, :START_CANDIDATES]
    expected = grid[nearest.min(1)]  # all tie: the lowest row of the k nearest
    for noise in (0.0, 1e-3 * COST_QUANTUM):

        def cost(p, lab, rows, noise=noise):
            return 7.0 + noise * rng.standard_normal(len(p))

        assert np.array_equal(cost_rank(cost(grid, grid_lab, None)), np.full(len(grid), 7e6))
        np.testing.assert_array_equal(_start(deep, target, cost), expected)
