"""Move a shell's vertices by a tiny random amount so that no disjoint faces are coplanar.

A robust shell (:mod:`shellvox.offset.reference.robust`) is made of flat regions, one per moved face
plane, each triangulated into many triangles whose vertices lie on the plane to within round-off
(about ``1e-16`` of the coordinates). Two triangles of one plane that share no vertex and whose
bounding boxes overlap are disjoint, but a triangle-triangle test without a coplanarity tolerance
cannot tell: the signed distances of one triangle's corners to the other's plane are pure round-off,
and Moeller's interval test [1]_ then answers at random. MeshLab's "Select Self Intersecting Faces"
(vcg's ``Clean::SelfIntersections`` and ``NoDivTriTriIsect``) is such a test: vcg's
``triangle_triangle3.h`` defines ``USE_EPSILON_TEST`` but tests ``#ifdef
USE_TRI_TRI_INT_EPSILON_TEST``, so its coplanarity tolerance is never compiled in, and it flagged
230 to 500 faces of each bunny and spot shell (every one beside a coplanar, disjoint face), and a
different number in a process that had loaded another mesh first.

:func:`jitter_vertices` removes the cause rather than the symptom: the vertices of every
such pair (:func:`shellvox.offset.crossing.intersections.coplanar_pairs`; except in planes ``x_k =
c`` held exactly, where every test computes exact zeros) move by ``amplitude`` in a random
direction, so corners lie ``~amplitude`` off the other triangles' planes, 1e8 times the round-off,
and any floating-point test decides correctly; vertices elsewhere stay. Two triangles farther apart
than ``2 * amplitude`` cannot come to meet, and a face at least ``tol`` high
(:mod:`shellvox.offset.reference.clean`) turns by at most ``2 * amplitude / tol`` (1e-3 rad at the
defaults), so only configurations that already touch can change: a face folded flat onto its
neighbour, or lying on another along a line. Those are found (new crossing pairs of
:func:`shellvox.offset.crossing.intersections.intersecting_pairs`, new folds of
:func:`shellvox.offset.reference.clean.folded_faces`), their vertices are kept in place, and the
rest are moved again; if that does not settle after :data:`MAX_FREEZES` attempts, the input is
returned unchanged. A crossing smaller than the crossing test's tolerance (1e-10 of the extent)
would go unseen; at 100 times that amplitude none was left on the icosphere, bunny, spot, cylinder,
capsule, torus and fan-triangulated box shells (MeshLab flags none), where at 10 times it MeshLab
still flagged a few faces of a torus's shells.

References
----------
.. [1] T. Moeller, "A fast triangle-triangle intersection test", Journal of Graphics
   Tools 2(2), 1997.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.crossing.intersections import (
    JITTER_FRACTION,
    coplanar_pairs,
    intersecting_pairs,
)
from shellvox.offset.reference.clean import folded_faces

#: Attempts with more vertices kept in place (see :func:`jitter_vertices`).
MAX_FREEZES = 4


@dataclass(frozen=True)
class JitteredMesh:
    """A mesh after :func:`jitter_vertices`.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    amplitude_mm : float, mm
        How far each moved vertex moved (0 when the input was returned unchanged).
    n_moved : int
        Vertices moved.
    n_kept : int
        Vertices of coplanar pairs kept in place because moving them made faces cross
        or fold.
    coplanar_pairs : int
        Pairs of :func:`shellvox.offset.crossing.intersections.coplanar_pairs` left, but for those
        in a plane ``x_k = c`` held exactly.
    """

    vertices: FloatArray
    amplitude_mm: float
    n_moved: int
    n_kept: int
    coplanar_pairs: int


def jitter_vertices(
    vertices: FloatArray,
    faces: IntArray,
    *,
    amplitude: float | None = None,
    seed: int = 0,
) -> JitteredMesh:
    """Move the vertices of coplanar pairs by `amplitude` at random, without new crossings.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).
    amplitude : float, optional, mm
        Distance each vertex moves; by default :data:`JITTER_FRACTION` of the extent.
        Must be > 0.
    seed : int, optional
        Seed of the directions (the result is reproducible).

    Returns
    -------
    JitteredMesh
        Same faces; no more crossing pairs and folded faces than the input.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    if amplitude is None:
        amplitude = JITTER_FRACTION * (float(np.ptp(v, axis=0).max()) if len(v) else 0.0)
    elif not amplitude > 0:
        raise ValueError(f"amplitude must be > 0 mm, got {amplitude!r}")
    coplanar = _ambiguous(v, f, coplanar_pairs(v, f))
    if len(coplanar) == 0 or not amplitude > 0:
        return JitteredMesh(v, 0.0, 0, 0, len(coplanar))
    step = np.random.default_rng(seed).normal(size=v.shape)
    step *= amplitude / np.linalg.norm(step, axis=1, keepdims=True)
    target = np.zeros(len(v), dtype=bool)
    target[f[coplanar.reshape(-1)].reshape(-1)] = True
    crossing = len(intersecting_pairs(v, f))
    folded = len(folded_faces(v, f))
    kept = np.zeros(len(v), dtype=bool)
    for _ in range(MAX_FREEZES + 1):
        moves = target & ~kept
        moved = v + np.where(moves[:, None], step, 0.0)
        pairs = intersecting_pairs(moved, f)
        folds = folded_faces(moved, f)
        if len(pairs) <= crossing and len(folds) <= folded:
            return JitteredMesh(
                moved,
                float(amplitude),
                int(np.count_nonzero(moves)),
                int(np.count_nonzero(target & kept)),
                len(_ambiguous(moved, f, coplanar_pairs(moved, f))),
            )
        kept |= _touching(f, np.union1d(pairs.reshape(-1), folds), len(v))
    return JitteredMesh(v, 0.0, 0, int(np.count_nonzero(target)), len(coplanar))


def _ambiguous(v: FloatArray, f: IntArray, pairs: IntArray) -> IntArray:
    """Return the coplanar `pairs` whose six corners do not share one coordinate exactly.

    In a plane ``x_k = c`` held exactly, every test's distances are exact zeros (the
    normal comes out as a unit axis), so such pairs are not ambiguous and stay exact.
    """
    corners = np.concatenate([v[f[pairs[:, 0]]], v[f[pairs[:, 1]]]], axis=1)  # (P, 6, 3)
    axis_plane = np.any(np.all(corners == corners[:, :1], axis=1), axis=1)
    return np.asarray(pairs[~axis_plane], dtype=np.int64)


def _touching(f: IntArray, bad_faces: IntArray, n: int) -> npt.NDArray[np.bool_]:
    """Return the vertices of `bad_faces` and of every face sharing a vertex with them."""
    ring = np.zeros(n, dtype=bool)
    ring[f[bad_faces].reshape(-1)] = True
    ring[f[np.any(ring[f], axis=1)].reshape(-1)] = True
    return ring
