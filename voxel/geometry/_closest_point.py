"""Compiled closest point of a triangle (Ericson's Voronoi-region test), for the kernels.

:func:`closest_weights` is the numpy version's arithmetic (:func:`shellvox.voxel.geometry._nearest.
closest_barycentric`) term for term, so the colour kernel's barycentric coordinates
equal it bit for bit; :func:`triangle_d2` turns the same weights into the squared
distance the nearest-face scan needs, with a degenerate (zero-area) triangle measured
to its edges. IEEE division (``error_model="numpy"``) as in numpy.

References
----------
.. [1] C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, section 5.1.5.
"""

from __future__ import annotations

import math

from shellvox.voxel._compiled import kernel


@kernel
def closest_weights(
    p0: float, p1: float, p2: float,
    a0: float, a1: float, a2: float,
    b0: float, b1: float, b2: float,
    c0: float, c1: float, c2: float,
) -> tuple[float, float]:  # fmt: skip
    """Weights ``(v, w)`` of ``b`` and ``c`` of the closest point of the triangle to ``p``.

    Regions from the highest priority down (the numpy version assigns them upwards); a
    zero-area triangle that falls in no region gives non-finite weights, as there.
    """
    ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
    ac0, ac1, ac2 = c0 - a0, c1 - a1, c2 - a2
    ap0, ap1, ap2 = p0 - a0, p1 - a1, p2 - a2
    d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2
    d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2
    ab_ab = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    ab_ac = ab0 * ac0 + ab1 * ac1 + ab2 * ac2
    ac_ac = ac0 * ac0 + ac1 * ac1 + ac2 * ac2
    d3, d4, d5, d6 = d1 - ab_ab, d2 - ab_ac, d1 - ab_ac, d2 - ac_ac
    if d1 <= 0 and d2 <= 0:
        return 0.0, 0.0
    if d3 >= 0 and d4 <= d3:
        return 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        return d1 / (d1 - d3), 0.0
    if d6 >= 0 and d5 <= d6:
        return 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        return 0.0, d2 / (d2 - d6)
    va = d3 * d6 - d5 * d4
    if va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 1.0 - w_bc, w_bc
    total = va + vb + vc
    return vb / total, vc / total


@kernel
def triangle_d2(
    p0: float, p1: float, p2: float,
    a0: float, a1: float, a2: float,
    b0: float, b1: float, b2: float,
    c0: float, c1: float, c2: float,
) -> float:  # fmt: skip
    """Exact squared distance from ``p`` to the triangle ``a b c``."""
    v, w = closest_weights(p0, p1, p2, a0, a1, a2, b0, b1, b2, c0, c1, c2)
    if not (v >= 0.0 and w >= 0.0 and v + w <= 1.0):  # zero area: its nearest edge
        return min(
            _segment_d2(p0, p1, p2, a0, a1, a2, b0, b1, b2),
            _segment_d2(p0, p1, p2, b0, b1, b2, c0, c1, c2),
            _segment_d2(p0, p1, p2, c0, c1, c2, a0, a1, a2),
        )
    u = 1.0 - v - w
    d0 = p0 - (u * a0 + v * b0 + w * c0)
    d1 = p1 - (u * a1 + v * b1 + w * c1)
    d2 = p2 - (u * a2 + v * b2 + w * c2)
    return d0 * d0 + d1 * d1 + d2 * d2


@kernel
def _segment_d2(
    p0: float, p1: float, p2: float,
    a0: float, a1: float, a2: float,
    b0: float, b1: float, b2: float,
) -> float:  # fmt: skip
    """Squared distance from ``p`` to the segment ``a b`` (a point if ``a == b``)."""
    u0, u1, u2 = b0 - a0, b1 - a1, b2 - a2
    length2 = u0 * u0 + u1 * u1 + u2 * u2
    t = 0.0
    if length2 > 0.0:
        t = min(1.0, max(0.0, ((p0 - a0) * u0 + (p1 - a1) * u1 + (p2 - a2) * u2) / length2))
    d0, d1, d2 = p0 - (a0 + t * u0), p1 - (a1 + t * u1), p2 - (a2 + t * u2)
    return d0 * d0 + d1 * d1 + d2 * d2


@kernel
def barycentric(
    p0: float, p1: float, p2: float,
    a0: float, a1: float, a2: float,
    b0: float, b1: float, b2: float,
    c0: float, c1: float, c2: float,
) -> tuple[float, float]:  # fmt: skip
    """:func:`closest_weights`, with ``(0, 0)`` where they are not finite (numpy's rule)."""
    v, w = closest_weights(p0, p1, p2, a0, a1, a2, b0, b1, b2, c0, c1, c2)
    if not (math.isfinite(v) and math.isfinite(w)):
        return 0.0, 0.0
    return v, w
