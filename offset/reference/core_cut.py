"""The Boolean steps of a robust shell: cut the core, uncross it, patch it locally.

:func:`cut_core` subtracts the union of a layer's pieces from the previous core,
:func:`uncross` simplifies a shell whose triangles cross, and :func:`patch_core`
recomputes the core in boxes around defective triangles; :mod:`shellvox.offset.reference.robust`
strings them together (its docstring explains when each step runs and why).
"""

from __future__ import annotations

import manifold3d as m3d
import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.mesh_diff import face_origin
from shellvox.offset.reference.union import to_manifold, union_pieces

#: Extra subtraction rounds where a Boolean left part of the previous boundary behind.
REPAIR_ROUNDS = 3
#: Components thinner on average than this fraction of the depth, or smaller than this
#: fraction of the extent cubed, are dropped as slivers.
SLIVER_FRACTION = 1e-6
#: Tolerance (fraction of the smallest depth) to which a crossing shell is simplified:
#: manifold3d collapses edges whose removal moves the surface less than this.
SIMPLIFY_FRACTION = 2e-7


def cut_core(
    base: m3d.Manifold,
    pieces: list[tuple[FloatArray, IntArray]],
    d_min: float,
    d_max: float,
    leaf: int,
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
        Leaf size of the union tree (:func:`shellvox.offset.reference.union.union_pieces`).

    Returns
    -------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    """
    min_thickness = SLIVER_FRACTION * d_min
    base_id = int(base.original_id())
    core = base - union_pieces(pieces, leaf=leaf)
    vert, tri, leftover = mesh_arrays(core, base_id, min_thickness)
    for _ in range(REPAIR_ROUNDS):
        if not np.any(leftover):
            break
        # The previous boundary lies shallower than every piece reaches, so none of it
        # may survive: the Boolean mis-classified a region. Subtract the pieces around
        # it once more.
        near = scipy.spatial.cKDTree(vert[tri[leftover]].reshape(-1, 3))
        local = [(p[_near(p, near, d_max)], t) for p, t in pieces]
        core = core - union_pieces(local, leaf=leaf)
        vert, tri, leftover = mesh_arrays(core, base_id, min_thickness)
    return vert, tri


def uncross(
    vert: FloatArray,
    tri: IntArray,
    d_min: float,
    previous: tuple[FloatArray, IntArray, npt.NDArray[np.bool_]] | None = None,
) -> tuple[FloatArray, IntArray, npt.NDArray[np.bool_], int]:
    """Return the shell, simplified if it crosses itself, and what still crosses.

    Crossings are mostly of sub-micrometre triangles: manifold3d collapses them when the
    shell is simplified to ``SIMPLIFY_FRACTION * d_min``. Those that survive are repaired
    by :func:`patch_core`.

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
        s_vert, s_tri, _ = mesh_arrays(
            to_manifold(vert, tri).simplify(SIMPLIFY_FRACTION * d_min),
            -1,
            SLIVER_FRACTION * d_min,
        )
        pairs = _crossing_pairs(s_vert, s_tri, (vert, tri, crossing))
        vert, tri = s_vert, s_tri
    mask = np.zeros(len(tri), dtype=bool)
    mask[pairs.reshape(-1)] = True
    return vert, tri, mask, len(pairs)


def _crossing_pairs(
    vert: FloatArray,
    tri: IntArray,
    previous: tuple[FloatArray, IntArray, npt.NDArray[np.bool_]] | None,
) -> IntArray:
    """Return the crossing pairs of a shell, testing only what changed since `previous`.

    Faces with the same corners as a face of the previous shell
    (:func:`shellvox.offset.reference.mesh_diff.face_origin`) that did not cross there cannot cross
    each other here; every pair with a new face or a formerly crossing one is tested.

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


def patch_core(
    base: m3d.Manifold,
    pieces: list[tuple[FloatArray, IntArray]],
    vert: FloatArray,
    tri: IntArray,
    bad: npt.NDArray[np.bool_],
    d_min: float,
    pad: float,
    leaf: int,
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
    vert, tri, leftover = mesh_arrays(core, base_id, SLIVER_FRACTION * d_min)
    if np.any(leftover):  # see cut_core
        near = scipy.spatial.cKDTree(vert[tri[leftover]].reshape(-1, 3))
        nearby = [(p[_near(p, near, pad)], t) for p, t in local]
        vert, tri, _ = mesh_arrays(
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
        scipy.sparse.coo_matrix(
            (np.ones(int(meet.sum())), (i[meet], j[meet])), shape=(n_tri, n_tri)
        ),
        directed=False,
    )
    n = int(label.max()) + 1
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, label, t_lo)
    np.maximum.at(hi, label, t_hi)
    return lo, hi


def mesh_arrays(
    core: m3d.Manifold, base_id: int, min_thickness: float
) -> tuple[FloatArray, IntArray, npt.NDArray[np.bool_]]:
    """Return sliver-free vertices and triangles, and which triangles stem from the base.

    Parameters
    ----------
    core : manifold3d.Manifold
    base_id : int
        Original ID of the solid the pieces were cut from.
    min_thickness : float, mm
        See :func:`drop_slivers`.

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
    vert, tri, keep = drop_slivers(vert, tri, min_thickness)
    return vert, tri, tri_id[keep] == base_id


def _near(points: FloatArray, tree: scipy.spatial.cKDTree, margin: float) -> npt.NDArray[np.bool_]:
    """Return which pieces ``(N, P, 3)`` come within `margin` of a point in `tree`."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    centre = 0.5 * (points.min(axis=1) + points.max(axis=1))
    radius = np.linalg.norm(points.max(axis=1) - points.min(axis=1), axis=1)
    dist, _ = tree.query(centre)
    return np.asarray(dist <= radius + margin, dtype=bool)


def drop_slivers(
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
