"""The exact confirmation of crossing pairs, against an independent exact test.

The reference decides a pair by its edges: two triangles in general position meet iff an
edge of one passes through the other (orientation signs in rational arithmetic). On
random pairs in general position (none touching), that and Moeller's interval rule agree.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from shellvox.offset.crossing.exact_crossing import confirmed_crossings
from shellvox.offset.crossing.intersections import _crossing, intersecting_pairs

#: Two triangles of the layer-field shell of spot at 100 mm (step 0.1 mm) next to a node
#: where the field is nearly zero: the float test with its tolerance reports them.
NEAR_NODE = np.array(
    [
        [
            [-6.565445162730029, 7.595527175167618, -20.207467166861772],
            [-6.465445162730031, 7.595528069999766, -20.12905626607789],
            [-6.565429398605204, 7.595528069999766, -20.207451402736947],
        ],
        [
            [-6.565445162730029, 7.595528069999766, -20.20746378141837],
            [-6.465445162730031, 7.601184660025687, -20.107467166861774],
            [-6.543617615168323, 7.617355617561472, -20.107467166861774],
        ],
    ]
)


def _orient(a, b, c, d) -> int:
    m = [[Fraction(float(d_)) - Fraction(float(a_)) for a_, d_ in zip(a, p, strict=True)]
         for p in (b, c, d)]  # fmt: skip
    det = (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )
    return (det > 0) - (det < 0)


def _edge_through(p, q, t) -> bool:
    if _orient(*t, p) * _orient(*t, q) > 0:
        return False
    signs = [_orient(p, q, t[i], t[(i + 1) % 3]) for i in range(3)]
    return all(s >= 0 for s in signs) or all(s <= 0 for s in signs)


def _reference(a, b) -> bool:
    return any(
        _edge_through(x[i], x[(i + 1) % 3], y) for x, y in ((a, b), (b, a)) for i in range(3)
    )


def _random_pairs(rng, n, spread):
    """Pairs around the origin; `spread` sets how close the corners gather (mm)."""
    centre = rng.uniform(-50, 50, (n, 1, 1, 3))
    return centre + rng.normal(0.0, spread, (n, 2, 3, 3))


@pytest.mark.parametrize("spread", [1.0, 1e-6])
def test_agrees_with_the_edge_test_on_random_pairs(spread):
    rng = np.random.default_rng(7)
    pairs = _random_pairs(rng, 1500, spread)
    got = confirmed_crossings(pairs[:, 0], pairs[:, 1])
    want = np.array([_reference(a, b) for a, b in pairs])
    assert 100 < want.sum() < len(want) - 100  # both answers are common
    np.testing.assert_array_equal(got, want)


def test_a_near_node_pair_the_float_test_reports_is_not_a_crossing():
    a, b = NEAR_NODE
    assert _crossing(a[None], b[None], 1e-10 * 100.0).tolist() == [True]  # round-off
    assert not _reference(a, b)
    assert confirmed_crossings(a[None], b[None]).tolist() == [False]
    vertices = NEAR_NODE.reshape(-1, 3)
    assert len(intersecting_pairs(vertices, np.arange(6).reshape(2, 3))) == 0


def test_contacts_decided_as_the_float_test_decides_them_far_from_round_off():
    # Moeller's rule: no coplanar pairs, no point contacts; a contact along a segment
    # counts when one triangle straddles the other's plane.
    base = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]
    cases = {
        "coplanar overlap": [[0.5, 0.5, 0.0], [3.0, 0.5, 0.0], [0.5, 3.0, 0.0]],
        "corner on the face": [[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [1.0, 0.2, 1.0]],
        "edge on the face": [[0.2, 0.2, 0.0], [1.0, 0.5, 0.0], [0.5, 0.5, 1.0]],
        "through the face": [[0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [1.0, 0.2, 1.0]],
        "apart": [[0.5, 0.5, 0.5], [0.5, 0.5, 1.0], [1.0, 0.2, 1.0]],
    }
    a, b = np.array([base] * len(cases)), np.array(list(cases.values()))
    got = dict(zip(cases, confirmed_crossings(a, b).tolist(), strict=True))
    assert got == dict(zip(cases, _crossing(a, b, 1e-10).tolist(), strict=True))
    assert got["through the face"] and not got["coplanar overlap"]
    assert not got["corner on the face"] and not got["apart"]


def test_clear_cut_random_pairs_agree_with_the_float_test():
    pairs = _random_pairs(np.random.default_rng(3), 2000, 1.0)
    got = confirmed_crossings(pairs[:, 0], pairs[:, 1])
    np.testing.assert_array_equal(got, _crossing(pairs[:, 0], pairs[:, 1], 1e-10 * 100.0))


def _moeller_in_fractions(a, b) -> bool:
    """Moeller's interval rule of the module, every quantity a Fraction (slow reference)."""
    a = [tuple(Fraction(float(x)) for x in p) for p in a]
    b = [tuple(Fraction(float(x)) for x in p) for p in b]

    def sub(p, q):
        return tuple(x - y for x, y in zip(p, q, strict=True))

    def cross(u, v):
        return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])

    def dot(u, v):
        return sum(x * y for x, y in zip(u, v, strict=True))

    na, nb = cross(sub(a[1], a[0]), sub(a[2], a[0])), cross(sub(b[1], b[0]), sub(b[2], b[0]))
    db, da = [dot(na, sub(p, a[0])) for p in b], [dot(nb, sub(p, b[0])) for p in a]
    for d in (da, db):
        if all(x > 0 for x in d) or all(x < 0 for x in d) or all(x == 0 for x in d):
            return False
    if not (min(da) < 0 < max(da) or min(db) < 0 < max(db)):
        return False
    line = cross(na, nb)

    def interval(t, d):
        at = [dot(line, p) for p, x in zip(t, d, strict=True) if x == 0]
        for i in range(3):
            j = (i + 1) % 3
            if d[i] * d[j] < 0:
                s = d[i] / (d[i] - d[j])
                at.append(
                    dot(line, tuple(p + s * (q - p) for p, q in zip(t[i], t[j], strict=True)))
                )
        return min(at), max(at)

    (la, ha), (lb, hb) = interval(a, da), interval(b, db)
    return min(ha, hb) > max(la, lb)


def test_degenerate_pairs_decided_as_in_rational_arithmetic():
    # Shared corners, corners on the other's plane or edges, coplanar pairs and pairs a
    # rounding apart, at very different scales: the integer arithmetic of the module
    # decides each as the same rule does with every quantity a Fraction.
    rng = np.random.default_rng(11)
    grid = rng.integers(-2, 3, (3000, 2, 3, 3)).astype(np.float64)  # many exact contacts
    grid[:1000] *= 2.0**-40
    grid[1000:2000] = grid[1000:2000] * 1e3 + 0.1  # not dyadic: other denominators
    shared = rng.integers(0, 3, 3000)
    grid[np.arange(3000), 1, 0] = grid[np.arange(3000), 0, shared]  # one common corner
    grid[::3, 1, 1] += np.spacing(grid[::3, 1, 1])  # a rounding off a contact
    got = confirmed_crossings(grid[:, 0], grid[:, 1])
    want = np.array([_moeller_in_fractions(a, b) for a, b in grid])
    assert 50 < want.sum() < len(want) - 50
    np.testing.assert_array_equal(got, want)
