"""Convex pieces whose union is the band removed by :mod:`shellvox.offset.reference.robust`.

Every function returns same-topology pieces as ``points (N, P, 3) float64 mm`` plus one
shared triangle list ``tris (T, 3) int64`` (outward), or a list of such groups.
"""

from __future__ import annotations

import numpy as np
import trimesh

from shellvox.offset._validate import FloatArray, IntArray

#: Pieces reach this fraction of their depth outside the surface (avoids coplanar caps).
OUTSIDE_FRACTION = 0.05
#: Pieces reach this fraction of their depth beyond their face, edge or vertex along the
#: surface (overlap instead of coincidence); the depth error this adds is ~1e-8 relative.
GROW_FRACTION = 1e-3
#: Angular margin (radians) added around the rounded arc of edges and the cap of vertices.
MARGIN_RAD = np.radians(10.0)

Group = tuple[FloatArray, IntArray]


def prisms(tri: FloatArray, normals: FloatArray, d: FloatArray) -> Group:
    """Return face prisms ``T_f +- D_f n_f`` as ``(N, 6, 3)`` points and shared triangles.

    Each triangle is first grown about its incentre so that every edge moves out by
    ``GROW_FRACTION * D_f`` in its plane: neighbouring pieces then overlap instead of
    sharing faces exactly, and the surface's edges lie strictly inside the pieces, which
    keeps the Booleans away from coincident geometry. The cap stays exactly on the moved
    plane.

    Parameters
    ----------
    tri : (N, 3, 3) float64, mm
    normals : (N, 3) float64
        Unit outward normals.
    d : (N,) float64, mm
    """
    edge_len = np.linalg.norm(np.roll(tri, -1, axis=1) - np.roll(tri, 1, axis=1), axis=2)
    perimeter = edge_len.sum(axis=1)
    incentre = np.einsum("ni,nij->nj", edge_len, tri) / perimeter[:, None]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    inradius = area2 / perimeter
    reach = np.linalg.norm(tri - incentre[:, None, :], axis=2).max(axis=1)
    # Edges move out by GROW_FRACTION * D, corners by at most ten times that (slivers).
    grow = 1.0 + GROW_FRACTION * d * np.minimum(1.0 / inradius, 10.0 / reach)
    tri = incentre[:, None, :] + grow[:, None, None] * (tri - incentre[:, None, :])
    down = (d[:, None] * normals)[:, None, :]
    pts = np.concatenate([tri - down, tri + OUTSIDE_FRACTION * down], axis=1)
    tris = _ring_prism_topology(3)
    return _orient_rings(pts, tris, 3), tris


def sectors(
    ends: FloatArray, n1: FloatArray, n2: FloatArray, r: FloatArray, max_step: float
) -> list[Group]:
    """Return edge sector prisms covering the arc from ``-n1`` to ``-n2`` plus a margin.

    Each piece is the segment ``ends`` swept over a circular sector of radius ``r`` about
    the edge, with ring vertices exactly at ``-n1`` and ``-n2`` and equal steps of at most
    `max_step` between them (at least one); :data:`MARGIN_RAD` is added on both sides
    (capped so the sector stays convex), so nearly flat edges still get a solid piece.
    The chords stay within ``r (1 - cos(max_step / 2))`` of the arc.

    Parameters
    ----------
    ends : (N, 2, 3) float64, mm
    n1, n2 : (N, 3) float64
        Unit normals of the two faces (zero rows for degenerate faces).
    r : (N,) float64, mm
    max_step : float, radians

    Returns
    -------
    list of (points (n, 2m, 3) float64 mm, tris (T, 3) int64)
        One group per number of arc steps ``s``, with ``m = s + 4``.
    """
    t = ends[:, 1] - ends[:, 0]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    helper = np.where(np.abs(t[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    alt = np.cross(t, helper)
    alt /= np.linalg.norm(alt, axis=1, keepdims=True)
    u0 = -n1
    bad1 = np.linalg.norm(u0, axis=1) < 0.5
    u0[bad1] = alt[bad1]
    target = -n2
    bad2 = np.linalg.norm(target, axis=1) < 0.5
    w = np.cross(t, u0)
    phi2 = np.arctan2(np.einsum("ij,ij->i", target, w), np.einsum("ij,ij->i", target, u0))
    phi2[bad2] = 0.0
    w *= np.where(phi2 < 0, -1.0, 1.0)[:, None]
    span = np.abs(phi2)
    # Degenerate neighbours: a half disc; otherwise the arc plus a margin, at most pi.
    margin = np.minimum(MARGIN_RAD, 0.5 * np.maximum(np.pi - span, 0.0))
    margin[bad1 | bad2] = 0.5 * np.pi
    span[bad1 | bad2] = 0.0
    steps = np.maximum(np.ceil(span / max_step), 1).astype(np.int64)
    # The axis corner sits slightly outside the surface and the ends slightly beyond the
    # edge, so the edge itself lies strictly inside the piece (see prisms).
    outward = -(u0 + target)
    outward /= np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), 1e-300)
    good = ~(bad1 | bad2)
    groups: list[Group] = []
    for s in np.unique(steps):  # a few distinct step counts, not one per edge
        sel = np.flatnonzero(steps == s)
        k = np.arange(s + 1) / s
        ang = np.concatenate(
            [-margin[sel, None], span[sel, None] * k, (span[sel] + margin[sel])[:, None]],
            axis=1,
        )
        dirs = np.cos(ang)[..., None] * u0[sel, None, :] + np.sin(ang)[..., None] * w[sel, None, :]
        dirs[:, 1] = u0[sel]  # exactly -n1
        exact = np.flatnonzero(good[sel])
        dirs[exact, s + 1] = target[sel[exact]]  # exactly -n2
        rs = r[sel]
        axis_pt = (GROW_FRACTION * rs)[:, None, None] * outward[sel, None, :]
        ring = np.concatenate([axis_pt, rs[:, None, None] * dirs], axis=1)
        m = ring.shape[1]
        ext = (GROW_FRACTION * rs)[:, None] * t[sel]
        e = ends[sel]
        pts = np.concatenate(
            [(e[:, 0] - ext)[:, None] + ring, (e[:, 1] + ext)[:, None] + ring], axis=1
        )
        tris = _ring_prism_topology(m)
        groups.append((_orient_rings(pts, tris, m), tris))
    return groups


def vertex_caps(
    centres: FloatArray,
    r: FloatArray,
    axis: FloatArray,
    half_angle: FloatArray,
    max_step: float,
) -> list[Group]:
    """Return cones capped by spherical caps: ``hull(v, v + r * cap)`` about ``axis``.

    Each cap has ``ceil(half_angle / max_step)`` rings and enough points per ring (at
    least 6, a multiple of 2) that neighbouring points are at most `max_step` apart on
    the widest ring, so every facet of the cap stays within
    ``r (1 - cos(max_step / sqrt(2)))`` of the sphere.

    Parameters
    ----------
    centres : (N, 3) float64, mm
    r : (N,) float64, mm
    axis : (N, 3) float64
        Unit cap axes.
    half_angle : (N,) float64, radians in ``(0, pi / 2]``
        Angular radius of each cap.
    max_step : float, radians

    Returns
    -------
    list of (points (n, 2 + rings * azimuths, 3) float64 mm, tris (T, 3) int64)
        One group per resolution; points are apex, pole, then rings from the pole out.
    """
    rings = np.maximum(np.ceil(half_angle / max_step), 1).astype(np.int64)
    widest = np.sin(np.minimum(half_angle, np.pi / 2))
    azimuths = 2 * np.maximum(np.ceil(np.pi * widest / max_step), 3).astype(np.int64)
    groups: list[Group] = []
    for n_ring, n_az in np.unique(np.stack([rings, azimuths], axis=1), axis=0):
        sel = np.flatnonzero((rings == n_ring) & (azimuths == n_az))
        groups.append(
            _caps(centres[sel], r[sel], axis[sel], half_angle[sel], int(n_ring), int(n_az))
        )
    return groups


def _caps(
    centres: FloatArray,
    r: FloatArray,
    axis: FloatArray,
    half_angle: FloatArray,
    rings: int,
    azimuths: int,
) -> Group:
    """Return caps of one resolution, see :func:`vertex_caps`."""
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(axis, e1)
    polar = half_angle[:, None, None] * (np.arange(1, rings + 1) / rings)[None, :, None]
    az = (2 * np.pi * np.arange(azimuths) / azimuths)[None, None, :]
    sp = np.sin(polar)
    dirs = (
        np.cos(polar)[..., None] * axis[:, None, None, :]
        + (sp * np.cos(az))[..., None] * e1[:, None, None, :]
        + (sp * np.sin(az))[..., None] * e2[:, None, None, :]
    ).reshape(len(centres), rings * azimuths, 3)
    cap = np.concatenate([axis[:, None, :], dirs], axis=1) * r[:, None, None]
    apex = -(GROW_FRACTION * r)[:, None, None] * axis[:, None, :]  # just outside the surface
    pts = np.concatenate([apex, cap], axis=1) + centres[:, None, :]
    return pts, _cap_topology(rings, azimuths)


def balls(centres: FloatArray, r: FloatArray, subdivisions: int) -> Group:
    """Return inscribed icospheres of radius ``r`` about ``centres`` (``(N, P, 3)`` mm)."""
    ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    dirs = np.asarray(ico.vertices, dtype=np.float64)
    pts = centres[:, None, :] + r[:, None, None] * dirs[None]
    return pts, np.asarray(ico.faces, dtype=np.int64)


def _cap_topology(rings: int, azimuths: int) -> IntArray:
    """Outward triangles of the apex (0) + pole (1) + rings (2 ...) cap polytope."""
    a = np.arange(azimuths)
    a1 = (a + 1) % azimuths
    tris = [np.stack([np.ones_like(a), 2 + a, 2 + a1], axis=1)]
    for i in range(rings - 1):
        p, q = 2 + i * azimuths, 2 + (i + 1) * azimuths
        tris.append(np.stack([p + a, q + a, q + a1], axis=1))
        tris.append(np.stack([p + a, q + a1, p + a1], axis=1))
    last = 2 + (rings - 1) * azimuths
    tris.append(np.stack([np.zeros_like(a), last + a1, last + a], axis=1))
    return np.asarray(np.concatenate(tris), dtype=np.int64)


def _ring_prism_topology(m: int) -> IntArray:
    """Triangles of a prism over a convex ``m``-gon: ring 0 is ``0..m-1``, ring 1 ``m..2m-1``.

    Outward for one of the two ring orders; :func:`_orient_rings` swaps the rings of
    pieces whose signed volume is negative.
    """
    j = np.arange(1, m - 1)
    bottom = np.stack([np.zeros_like(j), j + 1, j], axis=1)
    top = np.stack([np.full_like(j, m), m + j, m + j + 1], axis=1)
    i = np.arange(m)
    i1 = (i + 1) % m
    side = np.concatenate([np.stack([i, i1, m + i1], axis=1), np.stack([i, m + i1, m + i], axis=1)])
    return np.asarray(np.concatenate([bottom, top, side]), dtype=np.int64)


def _orient_rings(points: FloatArray, tris: IntArray, m: int) -> FloatArray:
    """Swap the two rings of every piece whose signed volume is negative.

    Parameters
    ----------
    points : (N, 2m, 3) float64, mm
    tris : (T, 3) int64
    m : int

    Returns
    -------
    (N, 2m, 3) float64, mm
    """
    t = points[:, tris]  # (N, T, 3, 3)
    c = points.mean(axis=1)[:, None, :]
    vol = np.einsum("ntj,ntj->n", t[:, :, 0] - c, np.cross(t[:, :, 1] - c, t[:, :, 2] - c))
    flip = vol < 0
    out = points.copy()
    out[flip] = np.concatenate([points[flip, m:], points[flip, :m]], axis=1)
    return out
