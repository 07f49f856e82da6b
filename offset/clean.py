"""Remove degenerate triangles from a closed shell without changing its topology.

The robust shells (:mod:`offset.robust`) are exact where flat faces meet: where more than
three moved face planes nearly meet in one point (a vertex of valence above three, e.g.
every vertex of an icosphere), the exact offset has a cluster of vertices joined by edges
of 1e-10 to 1e-3 mm, and where the pieces' facets nearly coincide (reflex edges and
vertices) the Booleans leave more; manifold3d triangulates the faces around them into
slivers, down to zero area in float32. Such a mesh is valid in float64 but does not stand
up outside: merging the vertices a reader rounds together makes it non-manifold, and
tests of other tools see crossings among the slivers.

:func:`clean_degenerate` removes both kinds down to a length ``tol`` (mm):

* every cluster of vertices joined by edges shorter than ``tol`` is collapsed to its mean
  (clusters wider than ``MAX_CLUSTER * tol`` are left alone, so no vertex moves farther);
* every triangle whose height is below ``tol`` (a corner within ``tol`` of the opposite,
  longest edge) has that edge flipped, which moves the surface by less than the height.

A collapse is refused where it would make the mesh non-manifold (the link condition) or
turn a face over; a flip where it would duplicate an edge or turn a face over; the rounds
repeat until nothing changes. :func:`clean_shell` then checks the result with the
crossing test of :mod:`offset.intersections` and for faces folded flat onto a neighbour
(:func:`folded_faces`, a double layer that test does not see: flips and collapses among
slivers made a few on the bunny's shells) and, where it finds either, freezes the
vertices around them and cleans again, so the result is never less valid than the
input. manifold3d's own ``simplify`` does not do this: it collapses short edges
only below its internal epsilon (about ``1e-12`` of the extent, see ``CollapseShortEdges``
in its ``edge_op.cpp``) and keeps edges between faces that are not coplanar.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from offset._validate import FloatArray, IntArray
from offset.adjacency import edge_adjacency
from offset.intersections import intersecting_pairs
from offset.shells import Shell

BoolArray = npt.NDArray[np.bool_]

#: Tolerance of :func:`clean_offset_shell` as a fraction of the layer's smallest depth:
#: 1 um at 0.5 mm, far below a printer's layer (14 um and more), and a vertex moves at
#: most ``MAX_CLUSTER`` times that (0.8 % of the depth, within the caps' 1.1 %).
CLEAN_FRACTION = 2e-3
#: Largest extent (bounding-box diagonal) of a collapsed cluster, in units of ``tol``.
MAX_CLUSTER = 4.0
#: Rounds of collapse and flip.
MAX_ROUNDS = 12
#: Attempts per round to collapse the clusters left after refusing those that failed.
MAX_TRIES = 6
#: Attempts of :func:`clean_shell` with more vertices frozen around crossing triangles.
MAX_FREEZES = 3
#: A face at least ``tol`` high may turn by at most this angle in a collapse (cosine).
MIN_TURN_COS = 0.5
#: Two faces sharing an edge whose unit normals have a dot product below this are folded
#: flat onto each other (an opening angle below 0.08 degrees): a double layer of surface
#: that the crossing test, which ignores coplanar overlaps, does not see.
FOLD_COS = -1.0 + 1e-6


@dataclass(frozen=True)
class CleanedMesh:
    """A mesh after :func:`clean_degenerate` or :func:`clean_shell`.

    Attributes
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    tol_mm : float, mm
        The tolerance used (0 when the input was returned unchanged).
    n_collapsed : int
        Vertices removed by collapsing clusters.
    n_flipped : int
        Edges flipped.
    max_move_mm : float, mm
        Largest distance a vertex moved.
    short_edges : int
        Edges still shorter than the tolerance.
    thin_faces : int
        Faces still lower than the tolerance.
    """

    vertices: FloatArray
    faces: IntArray
    tol_mm: float
    n_collapsed: int
    n_flipped: int
    max_move_mm: float
    short_edges: int
    thin_faces: int


def clean_offset_shell(
    shell: Shell, *, fraction: float = CLEAN_FRACTION
) -> tuple[Shell, CleanedMesh]:
    """Return `shell` cleaned by :func:`clean_shell` at `fraction` of its smallest depth.

    Parameters
    ----------
    shell : Shell
        From :func:`offset.offset_shells`.
    fraction : float, optional
        Tolerance as a fraction of ``shell.depth_mm.min()``; must be > 0.

    Returns
    -------
    shell : Shell
        The same layer and depths with the cleaned vertices and faces.
    cleaned : CleanedMesh
        The same arrays and what was done.
    """
    if not fraction > 0:
        raise ValueError(f"fraction must be > 0, got {fraction!r}")
    tol = fraction * float(shell.depth_mm.min())
    if shell.faces.shape[0] == 0:
        return shell, CleanedMesh(shell.vertices, shell.faces, tol, 0, 0, 0.0, 0, 0)
    cleaned = clean_shell(shell.vertices, shell.faces, tol=tol)
    return replace(shell, vertices=cleaned.vertices, faces=cleaned.faces), cleaned


def clean_shell(vertices: FloatArray, faces: IntArray, *, tol: float) -> CleanedMesh:
    """Return the shell cleaned by :func:`clean_degenerate` with no new crossings.

    Where the cleaned mesh has more crossing triangle pairs (:func:`offset.intersections.
    intersecting_pairs`) or more folded faces (:func:`folded_faces`) than the input, the
    input vertices within ``2 * MAX_CLUSTER * tol`` of them are frozen and the mesh is
    cleaned again; after :data:`MAX_FREEZES` attempts the input is returned unchanged.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).
    tol : float, mm
        Shortest edge and smallest triangle height wanted; must be > 0.

    Returns
    -------
    CleanedMesh
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    before = len(intersecting_pairs(v, f))
    folds_before = len(folded_faces(v, f))
    frozen = np.zeros(len(v), dtype=bool)
    tree: scipy.spatial.cKDTree | None = None
    for _ in range(MAX_FREEZES + 1):
        cleaned, source = _clean(v, f, tol, frozen)
        pairs = intersecting_pairs(cleaned.vertices, cleaned.faces)
        folded = folded_faces(cleaned.vertices, cleaned.faces)
        if (
            len(pairs) <= before
            and len(folded) <= folds_before
            and _euler(cleaned.faces) == _euler(f)
        ):
            return cleaned
        bad = source[np.unique(cleaned.faces[np.union1d(pairs.reshape(-1), folded)])]
        tree = tree or scipy.spatial.cKDTree(v)
        near = tree.query_ball_point(v[bad.reshape(-1)], 2.0 * MAX_CLUSTER * tol)
        frozen[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])] = True
    return CleanedMesh(v, f, 0.0, 0, 0, 0.0, *_count_degenerate(v, f, tol))


def folded_faces(vertices: FloatArray, faces: IntArray) -> IntArray:
    """Return the faces folded flat onto a neighbour across an edge (see :data:`FOLD_COS`).

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).

    Returns
    -------
    (k,) int64
        Sorted face indices.
    """
    if faces.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    adj = edge_adjacency(faces)
    normal = _normals(vertices, faces)
    dot = np.einsum("ij,ij->i", normal[adj.face_left], normal[adj.face_right])
    fold = dot < FOLD_COS
    return np.asarray(
        np.unique(np.concatenate([adj.face_left[fold], adj.face_right[fold]])), dtype=np.int64
    )


def clean_degenerate(
    vertices: FloatArray, faces: IntArray, *, tol: float, frozen: BoolArray | None = None
) -> CleanedMesh:
    """Collapse edges shorter than `tol` and flip away triangles lower than `tol`.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).
    tol : float, mm
        Shortest edge and smallest triangle height wanted; must be > 0.
    frozen : (V,) bool, optional
        Vertices that must not move, nor lose or gain an edge.

    Returns
    -------
    CleanedMesh
        Closed, manifold and consistently oriented as the input, with the same Euler
        characteristic. Crossings are not checked here (see :func:`clean_shell`).
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    mask = np.zeros(len(v), dtype=bool) if frozen is None else np.asarray(frozen, dtype=bool)
    return _clean(v, f, tol, mask)[0]


def _clean(
    v: FloatArray, f: IntArray, tol: float, frozen: BoolArray
) -> tuple[CleanedMesh, IntArray]:
    """Return the cleaned mesh and the input index of each of its vertices."""
    if not tol > 0:
        raise ValueError(f"tol must be > 0 mm, got {tol!r}")
    if frozen.shape != (len(v),):
        raise ValueError(f"frozen must have shape ({len(v)},), got {frozen.shape}")
    origin = v
    source = np.arange(len(v))
    n_collapsed = n_flipped = 0
    for _ in range(MAX_ROUNDS):
        if f.shape[0] == 0:
            break
        v, f, keep, removed = _collapse(v, f, tol, frozen[source])
        source = source[keep]
        f, flipped = _flip(v, f, tol, frozen[source])
        n_collapsed += removed
        n_flipped += flipped
        if removed == 0 and flipped == 0:
            break
    moved = float(np.linalg.norm(v - origin[source], axis=1).max()) if len(v) else 0.0
    return (
        CleanedMesh(v, f, tol, n_collapsed, n_flipped, moved, *_count_degenerate(v, f, tol)),
        source,
    )


def _count_degenerate(v: FloatArray, f: IntArray, tol: float) -> tuple[int, int]:
    """Return the number of edges shorter, and of faces lower, than `tol`."""
    if f.shape[0] == 0:
        return 0, 0
    edges = _edges(f, len(v))[0]
    short = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1) < tol
    return int(np.count_nonzero(short)), int(np.count_nonzero(_heights(v, f)[0] < tol))


def _euler(f: IntArray) -> int:
    """Return ``V - E + F`` of the referenced vertices."""
    if f.shape[0] == 0:
        return 0
    n = int(f.max()) + 1
    return int(np.unique(f).size) - len(_edges(f, n)[0]) + int(f.shape[0])


def _edges(f: IntArray, n: int) -> tuple[IntArray, IntArray]:
    """Return the undirected edges ``(E, 2)`` (lower index first) and their keys."""
    a = f.reshape(-1)
    b = np.roll(f, -1, axis=1).reshape(-1)
    key = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    return np.stack([key // n, key % n], axis=1), key


def _heights(v: FloatArray, f: IntArray) -> tuple[FloatArray, IntArray]:
    """Return each face's height over its longest edge and that edge (0, 1, 2).

    Edge ``j`` joins corners ``j`` and ``(j + 1) % 3``.
    """
    tri = v[f]
    length = np.linalg.norm(np.roll(tri, -1, axis=1) - tri, axis=2)
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return area2 / np.maximum(length.max(axis=1), 1e-300), np.argmax(length, axis=1)


def _normals(v: FloatArray, f: IntArray) -> FloatArray:
    """Return unit face normals ``(F, 3)``; zero rows for faces of zero area."""
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.asarray(n / np.where(norm > 0, norm, np.inf))


def _vertex_normals(v: FloatArray, f: IntArray) -> FloatArray:
    """Return area-weighted vertex normals ``(V, 3)`` (not normalised)."""
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.zeros_like(v)
    for j in range(3):
        np.add.at(out, f[:, j], n)
    return out


def _collapse(
    v: FloatArray, f: IntArray, tol: float, frozen: BoolArray
) -> tuple[FloatArray, IntArray, IntArray, int]:
    """Collapse the clusters joined by short edges where that is safe.

    Returns the new vertices and faces, the kept vertex indices and how many went.
    """
    n = len(v)
    edges, _ = _edges(f, n)
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
    old_normal = _normals(v, f)
    old_height, _ = _heights(v, f)
    ref = _vertex_normals(v, f)[f].sum(axis=1)  # for faces too thin to have a normal
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
        tangled[_nonmanifold(g, n)] = True
        normal = _normals(new_v, g)
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


def _nonmanifold(f: IntArray, n: int) -> IntArray:
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


def _flip(v: FloatArray, f: IntArray, tol: float, frozen: BoolArray) -> tuple[IntArray, int]:
    """Flip the longest edge of every face lower than `tol` where that is safe."""
    height, j = _heights(v, f)
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
    g_height = _heights(v, f[g])[0]
    ref = np.where((g_height >= height[cand])[:, None], _normals(v, f[g]), _normals(v, f[cand]))
    n1, n2 = _normals(v, new1), _normals(v, new2)
    ok = (
        found
        & (p != q)
        & ~np.isin(pq, _edges(f, n)[1])
        & ~(frozen[a] | frozen[b] | frozen[p] | frozen[q])
        & (np.einsum("ij,ij->i", n1, ref) > 0)
        & (np.einsum("ij,ij->i", n2, ref) > 0)
        & (np.einsum("ij,ij->i", n1, n2) > 0)
        & (_heights(v, new1)[0] > height[cand])
        & (_heights(v, new2)[0] > height[cand])
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
