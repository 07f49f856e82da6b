"""Union of many small overlapping closed pieces with manifold3d, by spatial locality.

One Boolean over all pieces at once (or over batches that each span the whole model)
makes every intermediate result as large as the model. Here the pieces are ordered along
a Morton (Z-order) curve, runs of :data:`LEAF` neighbouring pieces are united first, and
the results are united pairwise up a balanced tree, so every Boolean joins two
neighbouring regions and the total work is about ``O(n log n)`` in the output size.
"""

from __future__ import annotations

import manifold3d as m3d
import numpy as np

from shellvox.offset._validate import FloatArray, IntArray

#: Pieces united by one manifold3d batch Boolean at the leaves of the union tree.
LEAF = 16
#: Bits per axis of the Morton code.
MORTON_BITS = 10


def to_manifold(vertices: FloatArray, faces: IntArray) -> m3d.Manifold:
    """Return the manifold3d solid of a closed mesh (float64 in, no merging)."""
    mesh = m3d.Mesh64(
        vert_properties=np.ascontiguousarray(vertices, dtype=np.float64),
        tri_verts=np.ascontiguousarray(faces, dtype=np.uint64),
    )
    return m3d.Manifold(mesh)


def morton_order(points: FloatArray) -> IntArray:
    """Return the permutation sorting `points` ``(N, 3)`` mm along a Z-order curve."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    lo = points.min(axis=0)
    span = max(float(np.ptp(points, axis=0).max()), 1e-300)
    q = np.floor((points - lo) / span * ((1 << MORTON_BITS) - 1)).astype(np.int64)
    code = np.zeros(len(points), dtype=np.int64)
    for bit in range(MORTON_BITS):
        for ax in range(3):
            code |= ((q[:, ax] >> bit) & 1) << (3 * bit + ax)
    return np.asarray(np.argsort(code, kind="stable"), dtype=np.int64)


def union_pieces(groups: list[tuple[FloatArray, IntArray]], *, leaf: int = LEAF) -> m3d.Manifold:
    """Return the union of closed pieces given as same-topology groups.

    Parameters
    ----------
    groups : list of (points (N, P, 3) float64 mm, tris (T, 3) int64)
        Each group holds ``N`` closed outward pieces sharing the triangle list ``tris``
        over their ``P`` points; ``P`` and ``T`` may differ between groups.
    leaf : int, optional
        Pieces united by one batch Boolean at the leaves of the tree. Manifold3d's
        results depend (within its tolerance) on the order of the Booleans; another leaf
        size gives another order.

    Returns
    -------
    manifold3d.Manifold
        Empty when there are no pieces.
    """
    groups = [(p, t) for p, t in groups if p.shape[0] > 0]
    if not groups:
        return m3d.Manifold()
    n_pts = np.concatenate([np.full(len(p), p.shape[1]) for p, _ in groups])
    n_tri = np.concatenate([np.full(len(p), len(t)) for p, t in groups])
    flat_v = np.concatenate([p.reshape(-1, 3) for p, _ in groups])
    # Per-piece start of its points / triangles in flat_v / flat_f (original order);
    # flat_f holds each piece's own triangles, numbered from 0.
    v_start = np.cumsum(n_pts) - n_pts
    f_start = np.cumsum(n_tri) - n_tri
    flat_f = np.concatenate([np.tile(t, (len(p), 1)) for p, t in groups])
    centre = np.concatenate([0.5 * (p.min(axis=1) + p.max(axis=1)) for p, _ in groups])
    order = morton_order(centre)
    # Gather points and triangles piece by piece in Morton order, renumbered.
    v_idx = _ranges(v_start[order], n_pts[order])
    f_idx = _ranges(f_start[order], n_tri[order])
    new_v_start = np.cumsum(n_pts[order]) - n_pts[order]
    shift = np.repeat(new_v_start, n_tri[order])
    verts = flat_v[v_idx]
    tris = flat_f[f_idx] + shift[:, None]
    # Leaves: `leaf` consecutive pieces; their points and triangles are contiguous.
    cut = np.arange(0, len(order), leaf)
    v_cut = np.r_[new_v_start[cut], len(verts)]
    f_cut = np.r_[(np.cumsum(n_tri[order]) - n_tri[order])[cut], len(tris)]
    level = [
        m3d.Manifold.batch_boolean(
            to_manifold(
                verts[v_cut[i] : v_cut[i + 1]], tris[f_cut[i] : f_cut[i + 1]] - v_cut[i]
            ).decompose(),
            m3d.OpType.Add,
        )
        for i in range(len(cut))
    ]
    _evaluate(level)
    while len(level) > 1:
        paired = [level[i] + level[i + 1] for i in range(0, len(level) - 1, 2)]
        level = paired + level[len(level) - len(level) % 2 :]
        _evaluate(level)
    return level[0]


def _evaluate(level: list[m3d.Manifold]) -> None:
    """Force manifold3d's lazy Booleans now.

    Left lazy, manifold3d flattens the nested unions of the tree into one batch union
    over everything, which loses the locality this module is for.
    """
    for solid in level:
        solid.num_tri()


def _ranges(start: IntArray, count: IntArray) -> IntArray:
    """Return the concatenation of ``arange(s, s + c)`` over ``start``, ``count``."""
    total = int(count.sum())
    offset = np.repeat(np.cumsum(count) - count, count)
    return np.asarray(np.repeat(start, count) + np.arange(total) - offset, dtype=np.int64)
