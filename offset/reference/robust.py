"""Robust per-face inward offset: the solid minus the union of per-feature swept pieces.

The layer-``k`` core is ``{x in P : dist(x, T_f) >= D_k(f) for every face f}`` (every
face's band, each of its own depth, removed from the solid ``P``); its boundary is shell
``k``. This is the classical offset-by-Minkowski-sum definition [1]_ with a per-face
radius. We realise it with mesh Booleans (manifold3d [2]_, float64 input and output)
rather than by intersecting neighbour planes (:mod:`shellvox.offset.reference.paper`) or on a grid:
the Boolean output is closed and oriented by construction, where the depth exceeds the local
thickness the core is simply empty there (the band fills the part), and layer ``k``'s core is cut
from layer ``k - 1``'s, so the shells are nested by construction. A level set [3]_ would also be
robust but chamfers convex creases to the voxel size, which breaks the exact flat faces and creases
asked for here. The removed set is the union of convex pieces
(:mod:`shellvox.offset.reference.band`, :mod:`shellvox.offset.reference.pieces`):

* a prism per face, ``T_f`` swept along its normal to ``-D_k(f)``: its cap is exactly the
  moved plane, so flat regions and convex creases come out exact (at a convex edge the
  two prisms overlap, so no other piece is needed there);
* a circular sector prism per reflex edge (any inward bend), radius the larger depth of its
  two faces, with corners exactly at ``-n_1`` and ``-n_2`` and the arc between them (the
  ideal rounded region) in equal steps of at most ``ARC_STEP_RAD`` (7.5 degrees);
* a cone with a spherical cap (points at most ``CAP_STEP_RAD``, 12 degrees, apart; or a
  whole icosphere where the normal cone is wider than a hemisphere) at each vertex of
  such an edge, radius the deepest incident face.

Error bounds: all polytopes are inscribed in the exact swept region, so the shell is never
deeper than asked except by the overlap below (at most ``5e-5 D``, at reflex features),
and at most ``D (1 - cos(3.75 deg)) = 0.21 % D`` shallower at reflex edges and
``D (1 - cos(12 deg / sqrt 2)) = 1.1 % D`` at reflex vertices (cap facets; the whole balls
used where the normal cone is wider than a hemisphere are icospheres of 642 points, within
about 0.5 % D); face interiors and convex creases are exact.

Depth steps: where neighbouring faces take different depths, each face's prism goes to
its own depth, so the shell steps sharply at the shared edge (moved by the overlap
``GROW_FRACTION * D``), as the voxel layers do: they take the depth of the nearest face
(:mod:`shellvox.voxel.geometry._layer_kernel`). The core as defined above would instead round the
deeper face's band under its shallower neighbour (a whole cylinder about the edge, a ball
about each corner): on a flat top with a 1.0 / 0.3 mm step the two differ by up to
0.7 mm next to the edge. Shells and voxels are kept to one rule, the voxels'; sectors
and caps at reflex features take the larger depth of their faces.

Pieces overlap their neighbours by ``GROW_FRACTION * D`` along the surface (sliver
triangles' corners by at most ten times that) so that no surface edge lies exactly on a
piece boundary; without it, Booleans left slivers of material along reflex edges.

The union is built bottom-up along a Morton curve (:mod:`shellvox.offset.reference.union`): runs of
16 neighbouring pieces first, then neighbouring results pairwise, each Boolean evaluated eagerly so
that every Boolean joins two neighbouring regions. Coplanar neighbouring faces of equal depth share
one prism (:mod:`shellvox.offset.reference.planar`).

manifold3d guarantees a manifold result, but not an embedded or exact one: near-coplanar
overlaps of pieces (nearly flat reflex edges) can leave sub-micrometre crossing
triangles, a folded triangle or a thin crack cut into the core, and which ones depends
on the order of the Booleans. Hence the guards (:mod:`shellvox.offset.reference.guards`), in this
order:

1. components of about zero volume are dropped (:func:`drop_slivers`);
2. where part of the previous boundary survived the cut (a mis-classified region), the
   nearby pieces are subtracted once more
   (:data:`shellvox.offset.reference.core_cut.REPAIR_ROUNDS`);
3. a shell with crossing triangles
(:func:`shellvox.offset.crossing.intersections.intersecting_pairs`) is
   simplified to ``shellvox.offset.reference.core_cut.SIMPLIFY_FRACTION * D`` (manifold3d's edge
   collapse);
4. where triangles still cross, or lie deeper than any piece reaches
   (:func:`shellvox.offset.reference.guards.too_deep`; a fold between layers that only touch is
   caught here, not by the crossing test), the core is recomputed locally (:func:`patch_core`): in
   boxes around them, from the previous core and the pieces reaching into the boxes, united in
   another order; the boxes grow each round (:data:`PATCH_ROUNDS`). After a simplification or a
   patch only pairs with a new triangle, or one that crossed before, are tested again
   (:mod:`shellvox.offset.reference.mesh_diff`);
5. a shell still defective after the patches is recomputed with another leaf size of
   the union tree (:data:`LEAF_SIZES`); the best attempt is kept, and a
   :class:`ShellDefectWarning` names what remains.

The input must be a closed, consistently oriented surface without self-intersections; a
self-intersecting input (e.g. the Khronos duck's bill) bounds no well-defined solid and
gives local defects there. The cost is that of the union, one pairwise Boolean per
piece (measured times: the documentation's performance page, ``bench_offset``).

References
----------
.. [1] J. R. Rossignac and A. A. G. Requicha, "Offsetting operations in solid
   modelling", Computer Aided Geometric Design 3(2), 1986.
.. [2] E. Lucas et al., "Manifold: a geometry library for topologically robust
   operations", https://github.com/elalish/manifold.
.. [3] D. Pavic and L. Kobbelt, "High-resolution volumetric computation of offset
   surfaces with feature preservation", Computer Graphics Forum 27(2), 2008.
"""

from __future__ import annotations

from typing import NamedTuple

import manifold3d as m3d
import numpy as np
import numpy.typing as npt

from shellvox.errors import warn
from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.reference.band import features, layer_pieces
from shellvox.offset.reference.core_cut import cut_core, patch_core, uncross
from shellvox.offset.reference.guards import Surface, too_deep
from shellvox.offset.reference.pieces import Group
from shellvox.offset.reference.union import LEAF, to_manifold

#: Leaf sizes of the union tree tried in turn while a layer's shell crosses itself.
LEAF_SIZES = (LEAF, 13, 11, 19)
#: Rounds of local recomputation around triangles deeper than asked (see :func:`patch_core`),
#: in boxes padded by ``round * PATCH_PAD * D``.
PATCH_ROUNDS = 3
PATCH_PAD = 1.0


class ShellDefectWarning(UserWarning):
    """A robust shell is still defective after every retry (see :data:`LEAF_SIZES`)."""


def robust_offset(
    vertices: FloatArray,
    faces: IntArray,
    depth: FloatArray,
) -> list[tuple[FloatArray, IntArray]]:
    """Return the boundary of the robust core for every cumulative depth.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented triangles.
    depth : (K, F) float64, mm
        Cumulative depth ``D_k(f)`` per layer and face, non-decreasing in ``k``.

    Returns
    -------
    list of (vertices (n, 3) float64 mm, faces (m, 3) int64)
        One outward-oriented mesh per layer, possibly empty or with several components.

    Warns
    -----
    ShellDefectWarning
        When a shell still has crossing triangles, or triangles deeper than asked (see
        :func:`shellvox.offset.reference.guards.too_deep_count`), after every union order was tried.
    """
    solid = to_manifold(vertices, faces)
    if solid.status() != m3d.Error.NoError:
        raise ValueError(
            f"vertices/faces must form a closed oriented manifold, got {solid.status()}"
        )
    feat = features(vertices, faces)
    surface = Surface(vertices, faces)
    out: list[tuple[FloatArray, IntArray]] = []
    base = solid.as_original()
    for k, d in enumerate(depth):
        shell = _layer_shell(base, layer_pieces(feat, d), surface, d)
        crossing, deep = shell.defects
        if crossing or deep:
            warn(
                f"robust shell of layer {k + 1}: {crossing} crossing triangle pairs and "
                f"{deep} triangles deeper than asked remain after every union order",
                ShellDefectWarning,
            )
        out.append((shell.vert, shell.tri))
        base = to_manifold(shell.vert, shell.tri).as_original()
    return out


class _Attempt(NamedTuple):
    """A shell of one layer and its defects.

    Attributes
    ----------
    vert : (n, 3) float64, mm
    tri : (m, 3) int64
    cross_tri : (m,) bool
        Triangles in a crossing pair.
    crossing : int
        Crossing triangle pairs.
    deep_tri : (m,) bool
        Triangles deeper than asked (:func:`shellvox.offset.reference.guards.too_deep`).
    """

    vert: FloatArray
    tri: IntArray
    cross_tri: npt.NDArray[np.bool_]
    crossing: int
    deep_tri: npt.NDArray[np.bool_]

    @property
    def defects(self) -> tuple[int, int]:
        """``(crossing pairs, triangles too deep)``: fewer is better, crossings first."""
        return self.crossing, int(np.count_nonzero(self.deep_tri))


def _layer_shell(
    base: m3d.Manifold, pieces: list[Group], surface: Surface, d: FloatArray
) -> _Attempt:
    """Return the best shell of a layer over the union orders (:data:`LEAF_SIZES`).

    Each order's core is cut from `base` (the previous layer's core: nested by
    construction) and patched (:func:`_patched`); the first without defects ends the
    search, else the one with the fewest (the first among equals) is kept.
    """
    best: _Attempt | None = None
    for leaf in LEAF_SIZES:
        attempt = _patched(_cut(base, pieces, surface, d, leaf), base, pieces, surface, d)
        if best is None or attempt.defects < best.defects:
            best = attempt
        if attempt.defects == (0, 0):
            break
    assert best is not None  # LEAF_SIZES is not empty
    return best


def _cut(
    base: m3d.Manifold, pieces: list[Group], surface: Surface, d: FloatArray, leaf: int
) -> _Attempt:
    """Return the core of `base` minus the `pieces`, united with leaf size `leaf`."""
    d_min = float(d.min())
    vert, tri = cut_core(base, pieces, d_min, float(d.max()), leaf)
    vert, tri, cross_tri, crossing = uncross(vert, tri, d_min)
    return _Attempt(vert, tri, cross_tri, crossing, too_deep(surface, d, vert, tri))


def _patched(
    attempt: _Attempt, base: m3d.Manifold, pieces: list[Group], surface: Surface, d: FloatArray
) -> _Attempt:
    """Return `attempt` with its defects recomputed locally, round after round.

    A fold or crack deeper than the pieces reach, or crossing triangles: the core is
    recomputed in boxes around them (padded by ``round * PATCH_PAD * max(d)``) from the
    previous core and the pieces there alone, united in another order
    (:func:`shellvox.offset.reference.core_cut.patch_core`). A round's result is kept unless it has
    more defects; the rounds end when none are left or after :data:`PATCH_ROUNDS`.
    """
    d_min, d_max = float(d.min()), float(d.max())
    for rnd in range(PATCH_ROUNDS):
        bad = attempt.deep_tri | attempt.cross_tri
        if not np.any(bad):
            break
        pad = (rnd + 1) * PATCH_PAD * d_max
        leaf = LEAF_SIZES[rnd % len(LEAF_SIZES)]
        vert, tri = patch_core(base, pieces, attempt.vert, attempt.tri, bad, d_min, pad, leaf)
        previous = (attempt.vert, attempt.tri, attempt.cross_tri)
        vert, tri, cross_tri, crossing = uncross(vert, tri, d_min, previous)
        patched = _Attempt(vert, tri, cross_tri, crossing, too_deep(surface, d, vert, tri))
        if patched.defects <= attempt.defects:
            attempt = patched
    return attempt
