"""The steps of cleaning a shell: collapse short edges, flip faces.

They make :func:`~shellvox.offset.reference.clean.clean_degenerate`.

Both work on whole arrays of one closed, manifold, consistently oriented mesh and refuse
what would break that (the link condition, faces turned over, duplicated edges); see
:mod:`shellvox.offset.reference.clean` for the procedure and its tolerances.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph

from shellvox.offset._validate import FloatArray, IntArray

BoolArray = npt.NDArray[np.bool_]

#: Largest extent (bounding-box diagonal) of a collapsed cluster, in units of ``tol``.
MAX_CLUSTER = 4.0
#: Attempts per round to collapse the clusters left after refusing those that failed.
MAX_TRIES = 6
#: A face at least ``tol`` high may turn by at most this angle in a collapse (cosine).
MIN_TURN_COS = 0.5


def count_degenerate(v: FloatArray, f: IntArray, tol: float) -> tuple[int, int]:
    """Return the number of edges shorter, and of faces lower, than `tol`."""
    if f.shape[0] == 0:
        return 0, 0
    edges = undirected_edges(f, len(v))[0]
    short = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1) < tol
    return int(np.count_nonzero(short)), int(np.count_nonzero(heights(v, f)[0] < tol))


def euler_characteristic(f: IntArray) -> int:
    """Return ``V - E + F`` of the referenced vertices."""
    if f.shape[0] == 0:
        return 0
    n = int(f.max()) + 1
    return int(np.unique(f).size) - len(undirected_edges(f, n)[0]) + int(f.shape[0])


def undirected_edges(f: IntArray, n: int) -> tuple[IntArray, IntArray]:
    """Return the undirected edges ``(E, 2)`` (lower index first) and their keys."""
    a = f.reshape(-1)
    b = np.roll(f, -1, axis=1).reshape(-1)
    key = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    return np.stack([key // n, key % n], axis=1), key


def heights(v: FloatArray, f: IntArray) -> tuple[FloatArray, IntArray]:
    """Return each face's height over its longest edge and that edge (0, 1, 2).

    Edge ``j`` joins corners ``j`` and ``(j + 1) % 3``.
    """
    tri = v[f]
    length = np.linalg.norm(np.roll(tri, -1, axis=1) - tri, axis=2)
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return area2 / np.maximum(length.max(axis=1), 1e-300), np.argmax(length, axis=1)


def unit_normals(v: FloatArray, f: IntArray) -> FloatArray:
    """Return unit face normals ``(F, 3)``; zero rows for faces of zero area."""
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.asarray(n / np.where(norm > 0, norm, np.inf))


def vertex_normals(v: FloatArray, f: IntArray) -> FloatArray:
    """Return area-weighted vertex normals ``(V, 3)`` (not normalised)."""
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.zeros_like(v)
    for j in range(3):
        np.add.at(out, f[:, j], n)
    return out


def collapse_clusters(
    v: FloatArray, f: IntArray, tol: float, frozen: BoolArray
) -> tuple[FloatArray, IntArray, IntArray, int]:
    """Collapse the clusters joined by short edges where that is safe.

    Returns the new vertices and faces, the kept vertex indices and how many went.
    """
    n = len(v)
    edges, _ = undirected_edges(f, n)
    short = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1) < tol
    short &= ~frozen[edges[:, 0]] & ~frozen[edges[:, 1]]
    unchanged = (v, f, np.arange(n), 0)
    if not np.any(short):
        return unchanged
    se = edges[short]
    _, label = scipy.sparse.csgraph.connected_components(
        scipy.sparse.coo_matrix((np.ones(len(se)), (se[:, 0], se[:, 1])), shape=(n, n)),
        directed=False,
    )
    n_label = int(label.max()) + 1
    size = np.bincount(label, minlength=n_label)
    lo = np.full((n_label, 3), np.inf)
    hi = np.full((n_label, 3), -np.inf)
    np.minimum.at(lo, label, v)
    np.maximum.at(hi, label, v)
    allowed = (size > 1) & (np.linalg.norm(hi - lo, axis=1) <= MAX_CLUSTER * tol)
    first = np.full(n_label, n)
    np.minimum.at(first, label, np.arange(n))
    mean = np.zeros((n_label, 3))
    np.add.at(mean, label, v)
    mean /= size[:, None]
    old_normal = unit_normals(v, f)
    old_height, _ = heights(v, f)
    ref = vertex_normals(v, f)[f].sum(axis=1)  # for faces too thin to have a normal
    # Target of each cluster: its mean, or where that turns a face over, the position
    # of one of its vertices (the representative).
    target = mean.copy()
    at_mean = np.ones(n_label, dtype=bool)
    for _ in range(MAX_TRIES):
        if not np.any(allowed):
            return unchanged
        take = allowed[label]
        rep = np.where(take, first[label], np.arange(n))
        new_v = np.where(take[:, None], target[label], v)
        g = rep[f]
        keep = (g[:, 0] != g[:, 1]) & (g[:, 1] != g[:, 2]) & (g[:, 2] != g[:, 0])
        g = g[keep]
        tangled = np.zeros(n, dtype=bool)
        tangled[nonmanifold_edges(g, n)] = True
        normal = unit_normals(new_v, g)
        thick = old_height[keep] >= tol
        turned = np.where(
            thick,
            np.einsum("ij,ij->i", normal, old_normal[keep]) < MIN_TURN_COS,
            np.einsum("ij,ij->i", normal, ref[keep]) <= 0.0,
        )
        flat = np.zeros(n, dtype=bool)
        flat[g[turned].reshape(-1)] = True
        bad_label = np.unique(label[take & (tangled | flat)[rep]])
        if bad_label.size == 0:
            used = np.zeros(n, dtype=bool)
            used[g.reshape(-1)] = True
            index = np.cumsum(used) - 1
            kept = np.flatnonzero(used)
            return new_v[used], index[g], kept, n - kept.size
        # Clusters that only turned a face try their representative's position once.
        retry = np.unique(label[take & flat[rep] & ~tangled[rep]])
        retry = retry[at_mean[retry]]
        target[retry] = v[first[retry]]
        at_mean[retry] = False
        allowed[np.setdiff1d(bad_label, retry)] = False
    return unchanged


def nonmanifold_edges(f: IntArray, n: int) -> IntArray:
    """Return the vertices on a non-manifold edge or with more than one fan of faces.

    In a closed oriented manifold every directed edge occurs once and its reverse once,
    and the corners around each vertex, linked across the edges, form one cycle.
    """
    a = f.reshape(-1)
    b = np.roll(f, -1, axis=1).reshape(-1)
    fwd = a * n + b
    order = np.argsort(fwd, kind="stable")
    sorted_fwd = fwd[order]
    same = sorted_fwd[1:] == sorted_fwd[:-1]
    dup = np.zeros(fwd.size, dtype=bool)
    dup[order[1:][same]] = True
    dup[order[:-1][same]] = True
    pos = np.minimum(np.searchsorted(sorted_fwd, b * n + a), fwd.size - 1)
    lonely = dup | (sorted_fwd[pos] != b * n + a)
    # Corner k (vertex a[k]) and the corner of a[k] in the face across edge a -> b: the
    # reverse half-edge b -> a ends there, so that corner is the next one in its face.
    partner = order[pos]
    across = (partner // 3) * 3 + (partner % 3 + 1) % 3
    ok = ~lonely
    m = fwd.size
    _, comp = scipy.sparse.csgraph.connected_components(
        scipy.sparse.coo_matrix(
            (np.ones(int(ok.sum())), (np.flatnonzero(ok), across[ok])), shape=(m, m)
        ),
        directed=False,
    )
    fans = np.bincount(np.unique(a * m + comp) // m, minlength=n)
    bad = np.concatenate([a[lonely], b[lonely], np.flatnonzero(fans > 1)])
    return np.asarray(np.unique(bad), dtype=np.int64)


def flip_low_faces(
    v: FloatArray, f: IntArray, tol: float, frozen: BoolArray
) -> tuple[IntArray, int]:
    """Flip the longest edge of every face lower than `tol` where that is safe."""
    height, j = heights(v, f)
    cand = np.flatnonzero(height < tol)
    if cand.size == 0:
        return f, 0
    n = len(v)
    a = f[cand, j[cand]]
    b = f[cand, (j[cand] + 1) % 3]
    p = f[cand, (j[cand] + 2) % 3]
    key = (f * n + np.roll(f, -1, axis=1)).reshape(-1)
    order = np.argsort(key)
    pos = np.minimum(np.searchsorted(key[order], b * n + a), key.size - 1)
    found = key[order][pos] == b * n + a
    half = order[pos]
    g = half // 3
    q = f[g, (half % 3 + 2) % 3]
    pq = np.minimum(p, q) * n + np.maximum(p, q)
    new1 = np.stack([p, a, q], axis=1)
    new2 = np.stack([q, b, p], axis=1)
    # The new faces must face as the higher face of the pair did (a thin face's normal
    # is mostly round-off), and as each other.
    g_height = heights(v, f[g])[0]
    higher = (g_height >= height[cand])[:, None]
    ref = np.where(higher, unit_normals(v, f[g]), unit_normals(v, f[cand]))
    n1, n2 = unit_normals(v, new1), unit_normals(v, new2)
    ok = (
        found
        & (p != q)
        & ~np.isin(pq, undirected_edges(f, n)[1])
        & ~(frozen[a] | frozen[b] | frozen[p] | frozen[q])
        & (np.einsum("ij,ij->i", n1, ref) > 0)
        & (np.einsum("ij,ij->i", n2, ref) > 0)
        & (np.einsum("ij,ij->i", n1, n2) > 0)
        & (heights(v, new1)[0] > height[cand])
        & (heights(v, new2)[0] > height[cand])
    )
    # One flip per face and per new edge each round: the lowest candidate wins.
    idx = np.flatnonzero(ok)
    idx = idx[np.argsort(height[cand[idx]], kind="stable")]
    rank = np.arange(idx.size)
    owner = np.full(len(f), idx.size)
    np.minimum.at(owner, cand[idx], rank)
    np.minimum.at(owner, g[idx], rank)
    _, first_pq = np.unique(pq[idx], return_index=True)
    win = (owner[cand[idx]] == rank) & (owner[g[idx]] == rank)
    win &= np.isin(rank, first_pq)
    idx = idx[win]
    out = f.copy()
    out[cand[idx]] = new1[idx]
    out[g[idx]] = new2[idx]
    return out, int(idx.size)
