"""Exact confirmation of triangle pairs that a floating-point test reports as crossing.

The compiled narrow phase of :func:`offset.intersections.intersecting_pairs` works in
float64 with a tolerance of ``1e-10`` of the mesh extent. Where many vertices gather within
about a micrometre of one point (the shells meshed from the layer field put several
vertices within ``1e-5`` of a grid step of a node where the field is nearly zero), its
rounding reports pairs that do not meet: on the 93,696-face spot at 100 mm, step 0.1 mm,
19 such pairs among 31.6 million triangles, none of which an exact test confirms. Each
reported pair is decided again here in exact rational arithmetic on the float64
coordinates (:class:`fractions.Fraction`), with the same rule as the float test (Moeller's
interval test [1]_):

* a pair crosses when each triangle meets the other's plane and the two segments in which
  they do overlap over a positive length along the planes' common line;
* coplanar pairs, contacts of zero length and contacts along a common line where neither
  triangle straddles the other's plane do not count.

The pairs reported are few (none to thousands), so a Python loop over them costs little
beside the float test over millions of candidates.

References
----------
.. [1] T. Moeller, "A fast triangle-triangle intersection test", Journal of Graphics
   Tools 2(2), 1997.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import numpy.typing as npt

Point = tuple[Fraction, Fraction, Fraction]


def confirmed_crossings(tri_a: npt.ArrayLike, tri_b: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Return which pairs of triangles cross, decided exactly.

    Parameters
    ----------
    tri_a, tri_b : (P, 3, 3) array_like of float64, mm
        The corners of the two triangles of each pair.

    Returns
    -------
    (P,) bool

    Examples
    --------
    >>> a = [[[0, 0, 0], [2, 0, 0], [0, 2, 0]]]
    >>> confirmed_crossings(a, [[[0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 0.2, 1]]]).tolist()
    [True]
    >>> confirmed_crossings(a, [[[0.5, 0.5, 1e-300], [0.5, 0.5, 1], [1.5, 0.2, 1]]]).tolist()
    [False]
    """
    a = np.asarray(tri_a, dtype=np.float64)
    b = np.asarray(tri_b, dtype=np.float64)
    return np.array([_crosses(_exact(p), _exact(q)) for p, q in zip(a, b, strict=True)], bool)


def _exact(triangle: npt.NDArray[np.float64]) -> list[Point]:
    return [(Fraction(x), Fraction(y), Fraction(z)) for x, y, z in triangle.tolist()]


def _sub(p: Point, q: Point) -> Point:
    return (p[0] - q[0], p[1] - q[1], p[2] - q[2])


def _cross(u: Point, v: Point) -> Point:
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _dot(u: Point, v: Point) -> Fraction:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _crosses(a: list[Point], b: list[Point]) -> bool:
    na = _cross(_sub(a[1], a[0]), _sub(a[2], a[0]))
    nb = _cross(_sub(b[1], b[0]), _sub(b[2], b[0]))
    db = [_dot(na, _sub(p, a[0])) for p in b]  # b's corners against plane a (scaled)
    da = [_dot(nb, _sub(p, b[0])) for p in a]
    if all(d > 0 for d in db) or all(d < 0 for d in db):
        return False
    if all(d > 0 for d in da) or all(d < 0 for d in da):
        return False
    if all(d == 0 for d in db) or all(d == 0 for d in da):
        return False  # coplanar (or a degenerate triangle)
    straddles_a = min(da) < 0 < max(da)
    straddles_b = min(db) < 0 < max(db)
    if not (straddles_a or straddles_b):
        return False  # a contact along the common line
    line = _cross(na, nb)
    low_a, high_a = _interval(a, da, line)
    low_b, high_b = _interval(b, db, line)
    return min(high_a, high_b) > max(low_a, low_b)


def _interval(tri: list[Point], d: list[Fraction], line: Point) -> tuple[Fraction, Fraction]:
    """Return where, along `line`, the triangle meets the other's plane (its ends)."""
    at = [_dot(line, p) for p, dp in zip(tri, d, strict=True) if dp == 0]
    for i in range(3):
        j = (i + 1) % 3
        if d[i] * d[j] < 0:
            share = d[i] / (d[i] - d[j])
            point = tuple(p + share * (q - p) for p, q in zip(tri[i], tri[j], strict=True))
            at.append(_dot(line, point))  # type: ignore[arg-type]
    return min(at), max(at)
