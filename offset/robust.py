"""Robust per-face inward offset: the solid minus the union of per-feature swept pieces.

The layer-``k`` core is ``{x in P : dist(x, T_f) >= D_k(f) for every face f}`` (every
face's band, each of its own depth, removed from the solid ``P``); its boundary is shell
``k``. This is the classical offset-by-Minkowski-sum definition [1]_ with a per-face
radius. We realise it with mesh Booleans (manifold3d [2]_, float64 input and output)
rather than by intersecting neighbour planes (:mod:`offset.paper`) or on a grid: the
Boolean output is closed and oriented by construction, where the depth exceeds the local
thickness the core is simply empty there (the band fills the part), and layer ``k``'s core
is cut from layer ``k - 1``'s, so the shells are nested by construction. A level set [3]_
would also be robust but chamfers convex creases to the voxel size, which breaks the exact
flat faces and creases asked for here. The removed set is the union of convex pieces
(:mod:`offset.band`, :mod:`offset.pieces`):

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
(:mod:`voxel.layer_kernel`). The core as defined above would instead round the deeper
face's band under its shallower neighbour (a whole cylinder about the edge, a ball
about each corner): on a flat top with a 1.0 / 0.3 mm step the two differ by up to
0.7 mm next to the edge. Shells and voxels are kept to one rule, the voxels'; sectors
and caps at reflex features take the larger depth of their faces.

Pieces overlap their neighbours by ``GROW_FRACTION * D`` along the surface (sliver
triangles' corners by at most ten times that) so that no surface edge lies exactly on a
piece boundary; without it, Booleans left slivers of material along reflex edges.

The union is built bottom-up along a Morton curve (:mod:`offset.union`): runs of 16
neighbouring pieces first, then neighbouring results pairwise, each Boolean evaluated
eagerly so that every Boolean joins two neighbouring regions. Coplanar neighbouring
faces of equal depth share one prism (:mod:`offset.planar`).

manifold3d guarantees a manifold result, but not an embedded or exact one: near-coplanar
overlaps of pieces (nearly flat reflex edges) can leave sub-micrometre crossing
triangles, a folded triangle or a thin crack cut into the core, and which ones depends
on the order of the Booleans. Hence the guards (:mod:`offset.guards`), in this order:

1. components of about zero volume are dropped (:func:`_drop_slivers`);
2. where part of the previous boundary survived the cut (a mis-classified region), the
   nearby pieces are subtracted once more (:data:`REPAIR_ROUNDS`);
3. a shell with crossing triangles (:func:`offset.intersections.intersecting_pairs`) is
   simplified to ``SIMPLIFY_FRACTION * D`` (manifold3d's edge collapse);
4. where triangles still cross, or lie deeper than any piece reaches
   (:func:`offset.guards.too_deep`; a fold between layers that only touch is caught
   here, not by the crossing test), the core is recomputed locally (:func:`_patch`): in
   boxes around them, from the previous core and the pieces reaching into the boxes,
   united in another order; the boxes grow each round (:data:`PATCH_ROUNDS`). After a
   simplification or a patch only pairs with a new triangle, or one that crossed
   before, are tested again (:mod:`offset.mesh_diff`);
5. a shell still defective after the patches is recomputed with another leaf size of
   the union tree (:data:`LEAF_SIZES`); the best attempt is kept, and a
   :class:`ShellDefectWarning` names what remains.

The input must be a closed, consistently oriented surface without self-intersections; a
self-intersecting input (e.g. the Khronos duck's bill) bounds no well-defined solid and
gives local defects there. The cost is that of the union, one pairwise Boolean per
piece, about 1 ms each on two cores; see ``benchmarks/bench_offset.py``.

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

import warnings

import manifold3d as m3d
import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from offset._validate import FloatArray, IntArray
from offset.band import features, layer_pieces
from offset.guards import Surface, too_deep
from offset.intersections import intersecting_pairs
from offset.mesh_diff import face_origin
from offset.union import LEAF, to_manifold, union_pieces

#: Extra subtraction rounds where a Boolean left part of the previous boundary behind.
REPAIR_ROUNDS = 3
#: Components thinner on average than this fraction of the depth, or smaller than this
#: fraction of the extent cubed, are dropped as slivers.
SLIVER_FRACTION = 1e-6
#: Tolerance (fraction of the smallest depth) to which a crossing shell is simplified:
#: manifold3d collapses edges whose removal moves the surface less than this.
SIMPLIFY_FRACTION = 2e-7
#: Leaf sizes of the union tree tried in turn while a layer's shell crosses itself.
LEAF_SIZES = (LEAF, 13, 11, 19)
#: Rounds of local recomputation around triangles deeper than asked (see :func:`_patch`),
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
        :func:`offset.guards.too_deep_count`), after every union order was tried.
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
        pieces = layer_pieces(feat, d)
        best: tuple[tuple[int, int], FloatArray, IntArray] | None = None
        d_min, d_max = float(d.min()), float(d.max())
        for leaf in LEAF_SIZES:
            # Nested by construction: layer k's core is cut from layer k - 1's.
            vert, tri = _cut(base, pieces, d_min, d_max, leaf)
            vert, tri, cross_tri, crossing = _uncross(vert, tri, d_min)
            deep_tri = too_deep(surface, d, vert, tri)
            for rnd in range(PATCH_ROUNDS):
                bad = deep_tri | cross_tri
                if not np.any(bad):
                    break
                # A fold or crack deeper than the pieces reach, or crossing triangles:
                # recompute the core in boxes around them from the previous core and
                # the pieces there alone, united in another order.
                p_vert, p_tri = _patch(
                    base, pieces, vert, tri, bad, d_min,
                    (rnd + 1) * PATCH_PAD * d_max, LEAF_SIZES[rnd % len(LEAF_SIZES)],
                )
                p_vert, p_tri, p_cross, p_crossing = _uncross(
                    p_vert, p_tri, d_min, (vert, tri, cross_tri)
                )
                p_deep = too_deep(surface, d, p_vert, p_tri)
                if (p_crossing, np.count_nonzero(p_deep)) <= (
                    crossing, np.count_nonzero(deep_tri)
                ):
                    vert, tri, cross_tri, crossing, deep_tri = (
                        p_vert, p_tri, p_cross, p_crossing, p_deep
                    )
            deep = int(np.count_nonzero(deep_tri))
            if best is None or (crossing, deep) < best[0]:
                best = ((crossing, deep), vert, tri)
            if crossing == 0 and deep == 0:
                break
        assert best is not None  # LEAF_SIZES is not empty
        (crossing, deep), vert, tri = best
        if crossing or deep:
            warnings.warn(
                f"robust shell of layer {k + 1}: {crossing} crossing triangle pairs and "
                f"{deep} triangles deeper than asked remain after every union order",
                ShellDefectWarning,
                stacklevel=3,
            )
        out.append((vert, tri))
        base = to_manifold(vert, tri).as_original()
    return out


def _cut(
    base: m3d.Manifold, pieces: list[tuple[FloatArray, IntArray]], d_min: float,
    d_max: float, leaf: int
) -> tuple[FloatArray, IntArray]:
    """Return ``base`` minus the union of ``pieces``, cleaned, as vertex / face arrays.

    Parameters
    ----------
    base : manifold3d.Manifold
        Marked original (its faces carry one original ID).
    pieces : list of (points (N, P, 3) float64 mm, tris (T, 3) int64)
    d_min, d_max : float, mm
        Smallest and largest depth of the layer.
    leaf : int
        Leaf size of the union tree (:func:`offset.union.union_pieces`).

    Returns
    -------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    """
    min_thickness = SLIVER_FRACTION * d_min
    base_id = int(base.original_id())
    core = base - union_pieces(pieces, leaf=leaf)
    vert, tri, leftover = _mesh_arrays(core, base_id, min_thickness)
    for _ in range(REPAIR_ROUNDS):
        if not np.any(leftover):
            break
        # The previous boundary lies shallower than every piece reaches, so none of it
        # may survive: the Boolean mis-classified a region. Subtract the pieces around
        # it once more.
        near = scipy.spatial.cKDTree(vert[tri[leftover]].reshape(-1, 3))
        local = [(p[_near(p, near, d_max)], t) for p, t in pieces]
        core = core - union_pieces(local, leaf=leaf)
        vert, tri, leftover = _mesh_arrays(core, base_id, min_thickness)
    return vert, tri


def _uncross(
    vert: FloatArray, tri: IntArray, d_min: float,
    previous: tuple[FloatArray, IntArray, npt.NDArray[np.bool_]] | None = None,
) -> tuple[FloatArray, IntArray, npt.NDArray[np.bool_], int]:
    """Return the shell, simplified if it crosses itself, and what still crosses.

    Crossings are mostly of sub-micrometre triangles: manifold3d collapses them when the
    shell is simplified to ``SIMPLIFY_FRACTION * d_min``. Those that survive are repaired
    by :func:`_patch`.

    Parameters
    ----------
    vert : (n, 3) float64, mm
    tri : (m, 3) int64
    d_min : float, mm
    previous : (vertices, faces, crossing_faces), optional
        A shell this one was made from by a local change (a patch), and which of its
        faces crossed: only the pairs with a face that is new or crossed before are
        tested (:func:`_crossing_pairs`). Every other pair was tested before.

    Returns
    -------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    crossing_faces : (m,) bool
        Faces of a crossing pair.
    n_pairs : int
        Number of crossing pairs.
    """
    pairs = _crossing_pairs(vert, tri, previous)
    if len(pairs):
        crossing = np.zeros(len(tri), dtype=bool)
        crossing[pairs.reshape(-1)] = True
        s_vert, s_tri, _ = _mesh_arrays(
            to_manifold(vert, tri).simplify(SIMPLIFY_FRACTION * d_min), -1,
            SLIVER_FRACTION * d_min,
        )
        pairs = _crossing_pairs(s_vert, s_tri, (vert, tri, crossing))
        vert, tri = s_vert, s_tri
    mask = np.zeros(len(tri), dtype=bool)
    mask[pairs.reshape(-1)] = True
    return vert, tri, mask, len(pairs)


def _crossing_pairs(
    vert: FloatArray, tri: IntArray,
    previous: tuple[FloatArray, IntArray, npt.NDArray[np.bool_]] | None,
) -> IntArray:
    """Return the crossing pairs of a shell, testing only what changed since `previous`.

    Faces with the same corners as a face of the previous shell
    (:func:`offset.mesh_diff.face_origin`) that did not cross there cannot cross each
    other here; every pair with a new face or a formerly crossing one is tested.

    Parameters
    ----------
    vert : (n, 3) float64, mm
    tri : (m, 3) int64
    previous : (vertices, faces, crossing_faces) or None
        None: test every pair.

    Returns
    -------
    (P, 2) int64
    """
    if previous is None:
        return intersecting_pairs(vert, tri)
    p_vert, p_tri, p_crossing = previous
    origin = face_origin(p_vert, p_tri, vert, tri)
    check = origin < 0
    check[origin >= 0] = p_crossing[origin[origin >= 0]]
    return intersecting_pairs(vert, tri, only=check)


def _patch(
    base: m3d.Manifold, pieces: list[tuple[FloatArray, IntArray]], vert: FloatArray,
    tri: IntArray, bad: npt.NDArray[np.bool_], d_min: float, pad: float, leaf: int,
) -> tuple[FloatArray, IntArray]:
    """Return the core recomputed inside boxes around the `bad` (deep or crossing) triangles.

    The region ``R`` is the union of axis-aligned boxes, one per cluster of bad
    triangles, padded by `pad`. The new core is ``(core - R) + ((base ^ R) - U)``, with
    ``U`` the union of the pieces whose bounding box meets ``R`` (exactly the pieces
    that matter inside ``R``), united in another order than the whole band. Both
    operands share only the planes of ``R``, so no near-coincident caps meet; the patch
    is cut from `base`, so the shells stay nested.

    Parameters
    ----------
    base : manifold3d.Manifold
        Marked original the core was cut from.
    pieces : list of (points (N, P, 3) float64 mm, tris (T, 3) int64)
    vert : (n, 3) float64, mm
    tri : (m, 3) int64
        The core's boundary.
    bad : (m,) bool
    d_min : float, mm
    pad : float, mm
    leaf : int
        Leaf size of the local union tree.

    Returns
    -------
    vertices : (n', 3) float64, mm
    faces : (m', 3) int64
    """
    lo, hi = _boxes(vert[tri[bad]], pad)
    region = m3d.Manifold.batch_boolean(
        [m3d.Manifold.cube(list(h - b)).translate(list(b)) for b, h in zip(lo, hi, strict=True)],
        m3d.OpType.Add,
    )
    local = []
    for p, t in pieces:
        p_lo, p_hi = p.min(axis=1), p.max(axis=1)
        meets = np.any(
            np.all((p_lo[:, None] <= hi[None]) & (p_hi[:, None] >= lo[None]), axis=2), axis=1
        )
        local.append((p[meets], t))
    base_id = int(base.original_id())
    core = (to_manifold(vert, tri) - region) + ((base ^ region) - union_pieces(local, leaf=leaf))
    vert, tri, leftover = _mesh_arrays(core, base_id, SLIVER_FRACTION * d_min)
    if np.any(leftover):  # see _cut
        near = scipy.spatial.cKDTree(vert[tri[leftover]].reshape(-1, 3))
        nearby = [(p[_near(p, near, pad)], t) for p, t in local]
        vert, tri, _ = _mesh_arrays(
            core - union_pieces(nearby, leaf=leaf), base_id, SLIVER_FRACTION * d_min
        )
    return vert, tri


def _boxes(tris: FloatArray, pad: float) -> tuple[FloatArray, FloatArray]:
    """Return padded bounding boxes ``(lo, hi)`` of the clusters of triangles ``(B, 3, 3)``.

    Triangles whose boxes, padded by `pad`, overlap belong to one cluster.
    """
    t_lo, t_hi = tris.min(axis=1) - pad, tris.max(axis=1) + pad
    centre, half = 0.5 * (t_lo + t_hi), 0.5 * (t_hi - t_lo)
    # Candidate pairs: centres close enough for the boxes to overlap, then exact test.
    pairs = scipy.spatial.cKDTree(centre).query_pairs(
        2.0 * float(np.linalg.norm(half, axis=1).max()), output_type="ndarray"
    )
    i, j = pairs[:, 0], pairs[:, 1]
    meet = np.all(np.abs(centre[i] - centre[j]) <= half[i] + half[j], axis=1)
    n_tri = len(tris)
    _, label = scipy.sparse.csgraph.connected_components(
        scipy.sparse.coo_matrix((np.ones(int(meet.sum())), (i[meet], j[meet])),
                                shape=(n_tri, n_tri)),
        directed=False,
    )
    n = int(label.max()) + 1
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, label, t_lo)
    np.maximum.at(hi, label, t_hi)
    return lo, hi


def _mesh_arrays(
    core: m3d.Manifold, base_id: int, min_thickness: float
) -> tuple[FloatArray, IntArray, npt.NDArray[np.bool_]]:
    """Return sliver-free vertices and triangles, and which triangles stem from the base.

    Parameters
    ----------
    core : manifold3d.Manifold
    base_id : int
        Original ID of the solid the pieces were cut from.
    min_thickness : float, mm
        See :func:`_drop_slivers`.

    Returns
    -------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    from_base : (m,) bool
    """
    mesh = core.to_mesh64()
    vert = np.ascontiguousarray(np.asarray(mesh.vert_properties)[:, :3], dtype=np.float64)
    tri = np.ascontiguousarray(np.asarray(mesh.tri_verts), dtype=np.int64).reshape(-1, 3)
    run_id = np.asarray(mesh.run_original_id, dtype=np.int64)
    run_index = np.asarray(mesh.run_index, dtype=np.int64) // 3
    tri_id = np.repeat(run_id, np.diff(run_index)) if run_id.size else np.full(len(tri), -1)
    vert, tri, keep = _drop_slivers(vert, tri, min_thickness)
    return vert, tri, tri_id[keep] == base_id


def _near(
    points: FloatArray, tree: scipy.spatial.cKDTree, margin: float
) -> npt.NDArray[np.bool_]:
    """Return which pieces ``(N, P, 3)`` come within `margin` of a point in `tree`."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    centre = 0.5 * (points.min(axis=1) + points.max(axis=1))
    radius = np.linalg.norm(points.max(axis=1) - points.min(axis=1), axis=1)
    dist, _ = tree.query(centre)
    return np.asarray(dist <= radius + margin, dtype=bool)


def _drop_slivers(
    vertices: FloatArray, faces: IntArray, min_thickness: float
) -> tuple[FloatArray, IntArray, npt.NDArray[np.bool_]]:
    """Remove flat or tiny components.

    Booleans of nearly coincident faces can leave closed needle components of about zero
    volume on the original surface; they bound no material. A component is dropped when
    its mean thickness ``3 |V| / A`` is below `min_thickness` or its volume below
    ``(1e-6 * extent)^3`` (far below any printer voxel).

    Parameters
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    min_thickness : float, mm

    Returns
    -------
    vertices : (n', 3) float64, mm
    faces : (m', 3) int64
        Unreferenced vertices removed.
    kept : (m,) bool
        Which input faces were kept.
    """
    if faces.shape[0] == 0:
        return vertices, faces, np.zeros(0, dtype=bool)
    graph = scipy.sparse.coo_matrix(
        (np.ones(faces.size), (faces.reshape(-1), np.roll(faces, 1, axis=1).reshape(-1))),
        shape=(len(vertices), len(vertices)),
    )
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    comp = label[faces[:, 0]]
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    vol = np.bincount(comp, np.einsum("ij,ij->i", tri[:, 0], cross) / 6.0)
    area = np.bincount(comp, 0.5 * np.linalg.norm(cross, axis=1))
    scale = float(np.ptp(vertices, axis=0).max())
    keep_comp = (3.0 * np.abs(vol) > min_thickness * area) & (
        np.abs(vol) > (SLIVER_FRACTION * scale) ** 3
    )
    keep = keep_comp[comp]
    used = np.zeros(len(vertices), dtype=bool)
    used[faces[keep].reshape(-1)] = True
    new_index = np.cumsum(used) - 1
    return (
        np.ascontiguousarray(vertices[used]),
        np.ascontiguousarray(new_index[faces[keep]]),
        keep,
    )


