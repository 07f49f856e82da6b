"""The two-flux model against its analytic limits, Kubelka's closed form and a numerical
solution of the two-flux equations (scipy's boundary-value solver)."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.integrate import solve_bvp

from shellvox.voxel.colour import (
    layer,
    mix,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
    srgb_to_lab_d50,
    stack,
)

RNG = np.random.default_rng(24)
K = RNG.uniform(0.01, 5.0, 40)
S = RNG.uniform(0.01, 30.0, 40)
BACKGROUND = RNG.uniform(0.0, 1.0, 40)


def test_a_thin_layer_shows_the_background():
    assert over(layer(K, S, 0.0), BACKGROUND) == pytest.approx(BACKGROUND, abs=1e-15)
    assert over(layer(K, S, 1e-9), BACKGROUND) == pytest.approx(BACKGROUND, rel=1e-6)


def test_a_deep_layer_reflects_r_infinity():
    ratio = K / S
    expected = 1 + ratio - np.sqrt(ratio**2 + 2 * ratio)  # Kubelka's R-infinity
    assert r_infinity(K, S) == pytest.approx(expected, rel=1e-12)
    for depth in (1e3, 1e6, np.inf):  # no overflow however deep
        reflectance, transmittance = layer(K, S, depth)
        assert reflectance == pytest.approx(expected, rel=1e-12)
        assert transmittance == pytest.approx(0.0, abs=1e-300)
        assert over(layer(K, S, depth), BACKGROUND) == pytest.approx(expected, rel=1e-12)


def test_without_scattering_light_is_absorbed_twice():
    t = RNG.uniform(0, 3, 40)
    reflectance, transmittance = layer(K, 0.0, t)
    assert reflectance == pytest.approx(0.0, abs=0)
    assert transmittance == pytest.approx(np.exp(-K * t), rel=1e-12)
    assert over(layer(K, 0.0, t), BACKGROUND) == pytest.approx(
        BACKGROUND * np.exp(-2 * K * t), rel=1e-12
    )


def test_without_absorption_over_black():
    t = RNG.uniform(0, 3, 40)
    assert over(layer(0.0, S, t), 0.0) == pytest.approx(S * t / (1 + S * t), rel=1e-12)
    assert layer(0.0, 0.0, np.inf).transmittance == pytest.approx(1.0)
    assert layer(0.0, 2.0, np.inf).reflectance == pytest.approx(1.0)


def test_kubelkas_exponential_closed_form_over_a_background():
    t = RNG.uniform(0.01, 2, 40)
    r_inf = r_infinity(K, S)
    growth = np.exp(S * t * (1 / r_inf - r_inf))
    expected = ((BACKGROUND - r_inf) / r_inf - r_inf * (BACKGROUND - 1 / r_inf) * growth) / (
        (BACKGROUND - r_inf) - (BACKGROUND - 1 / r_inf) * growth
    )
    assert over(layer(K, S, t), BACKGROUND) == pytest.approx(expected, rel=1e-9)


def test_two_half_layers_are_one_layer():
    t = RNG.uniform(0.01, 2, 40)
    halves = stack(np.stack([K, K]), np.stack([S, S]), np.stack([t / 2, t / 2]), BACKGROUND)
    assert halves == pytest.approx(over(layer(K, S, t), BACKGROUND), rel=1e-12)


def test_a_stack_is_built_from_the_bottom_up():
    k2, s2 = K[::-1], S[::-1]
    top_first = stack(np.stack([K, k2]), np.stack([S, s2]), np.stack([0.3, 0.7]), BACKGROUND)
    by_hand = over(layer(K, S, 0.3), over(layer(k2, s2, 0.7), BACKGROUND))
    assert top_first == pytest.approx(by_hand, rel=1e-14)


CASES = [(0.5, 3.0, 0.8, 0.9), (2.0, 0.5, 0.4, 0.1), (0.05, 20.0, 0.2, 0.5), (1.0, 1.0, 2.0, 0.0)]


@pytest.mark.parametrize(("k", "s", "t", "rb"), CASES)
def test_the_two_flux_equations_solved_numerically(k, s, t, rb):
    # i: flux going down (z into the layer), j: flux going up; i(0) = 1, j(t) = rb i(t).
    def equations(z, y):
        i, j = y
        return np.vstack([-(k + s) * i + s * j, (k + s) * j - s * i])

    def boundary(top, bottom):
        return np.array([top[0] - 1.0, bottom[1] - rb * bottom[0]])

    z = np.linspace(0, t, 200)
    solution = solve_bvp(equations, boundary, z, np.ones((2, z.size)), tol=1e-10, max_nodes=10**5)
    assert solution.success
    assert float(over(layer(k, s, t), rb)[()]) == pytest.approx(solution.sol(0.0)[1], abs=1e-6)
    transmitted = solution.sol(t)[0] * (1 - rb)  # what enters the background and stays
    r_layer, t_layer = layer(k, s, t)
    assert t_layer * (1 - rb) / (1 - r_layer * rb) == pytest.approx(transmitted, abs=1e-6)


def test_mixtures_sum_their_components():
    per_material = RNG.uniform(0, 5, (3, 31))
    fractions = np.array([[1.0, 0, 0], [0.2, 0.3, 0.5]])
    mixed = mix(fractions, per_material)
    assert mixed[0] == pytest.approx(per_material[0])
    assert mixed[1] == pytest.approx(
        0.2 * per_material[0] + 0.3 * per_material[1] + 0.5 * per_material[2]
    )


def test_saunderson_limits_and_monotonicity():
    r = np.linspace(0, 1, 101)
    measured = saunderson(r, 0.04, 0.6)
    assert measured[0] == pytest.approx(0.04) and measured[-1] == pytest.approx(1.0)
    assert np.all(np.diff(measured) > 0)
    assert saunderson(r, 0.0, 0.0) == pytest.approx(r)


def test_colorimetry_agrees_with_colour_science():
    seen = observer()
    d50 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
    assert seen.white_xy == pytest.approx(d50, abs=2e-3)  # D50, summed at 10 nm
    assert (np.ones(31) @ seen.weights)[1] == pytest.approx(1.0)
    flat = reflectance_to_lab(np.full(31, 0.18), seen)
    assert flat[1:] == pytest.approx([0, 0], abs=0.05) and flat[0] == pytest.approx(49.5, abs=0.2)
    # a real spectrum: colour-science's own integration at 1 nm against ours at 10 nm
    sd = colour.SDS_COLOURCHECKERS["BabelColor Average"]["dark skin"]
    with colour.utilities.suppress_warnings(colour_runtime_warnings=True):
        xyz = colour.sd_to_XYZ(sd, illuminant=colour.SDS_ILLUMINANTS["D50"]) / 100
    reference = colour.XYZ_to_Lab(xyz, d50)
    ours = reflectance_to_lab(sd.copy().align(colour.SpectralShape(400, 700, 10)).values, seen)
    assert colour.delta_E(ours, reference, method="CIE 2000") < 0.5


def test_srgb_white_is_the_d50_white():
    assert srgb_to_lab_d50([1.0, 1.0, 1.0]) == pytest.approx([100, 0, 0], abs=0.02)
    white = observer().white_xy  # adapted to the model's own white (the IEC matrix is rounded)
    assert srgb_to_lab_d50([1.0, 1.0, 1.0], white) == pytest.approx([100, 0, 0], abs=0.02)
    assert srgb_to_lab_d50(np.zeros((4, 2, 3))) == pytest.approx(np.zeros((4, 2, 3)), abs=1e-9)
