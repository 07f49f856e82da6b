"""Slicer paint: decode PrusaSlicer's triangle subdivision trees and split the mesh exactly.

PrusaSlicer (``slic3rpe:mmu_segmentation``), Bambu Studio and OrcaSlicer (``paint_color``)
store the multi-material paint of each triangle as a hexadecimal string: the
serialisation of a ``TriangleSelector`` tree (PrusaSlicer ``src/libslic3r/
TriangleSelector.cpp``, ``serialize`` / ``deserialize``, and ``Model.cpp``
``FacetsAnnotation::get_triangle_as_string``). Read from the last character to the
first, each hex digit is one 4-bit code. A node's code holds the number of split sides
in its low two bits; a leaf (0 split sides) holds its state in the high two bits, or
``0b11`` and then ``3 +`` the next code; a split node holds its *special side* in the high
two bits and is followed by its ``split + 1`` children, last child first. Splitting halves
edges at their midpoints (``perform_split``): with the corners rotated to start at the
special side, ``v0 v1 v2``, one split side gives ``(v0, v1, m12), (m12, v2, v0)``; two give
``(v0, m01, m02), (m01, v1, m02), (v1, v2, m02)``; three give ``(v0, m01, m02),
(m01, v1, m12), (m12, v2, m02), (m01, m12, m02)``. State 0 is unpainted (the volume's
extruder), state ``k`` is extruder ``k``.

:func:`split_painted` replaces each triangle by its leaves, so the paint boundary is the
one the user painted. Leaves of neighbouring triangles (or of one tree) need not meet
vertex to vertex: a leaf edge can have another leaf's corner in its middle (a
T-junction), which would leave the mesh open. Such a leaf is fanned around its centroid
through every corner that lies on its edges, so the result is closed whenever the input
was. Corners are kept as exact integer barycentric coordinates (``2**DEPTH`` per unit);
a corner on an input edge is keyed by that edge, so both triangles sharing it agree.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError

#: Deepest subdivision accepted (barycentric coordinates are integers of 2**DEPTH).
DEPTH = 40
SCALE = 1 << DEPTH
FIX = "re-save the project in the slicer"

_Corners = tuple[tuple[int, int, int], ...]


def decode(path: Path, text: str) -> list[tuple[_Corners, int]]:
    """Decode one triangle's paint string into leaves.

    Parameters
    ----------
    path : Path
        The model, for messages.
    text : str
        Hexadecimal paint string (empty: unpainted).

    Returns
    -------
    list of (corners, state)
        Each leaf's three corners as integer barycentric coordinates (each row sums to
        :data:`SCALE`) and its state.

    Examples
    --------
    >>> [state for _, state in decode(Path("m.3mf"), "8")]
    [2]
    >>> [state for _, state in decode(Path("m.3mf"), "481")]  # one split side, last child first
    [2, 1]
    """
    try:
        codes = [int(c, 16) for c in reversed(text.strip())]
    except ValueError:
        raise InputError(path, f"has a malformed paint string {text[:40]!r}", FIX) from None
    root: _Corners = ((SCALE, 0, 0), (0, SCALE, 0), (0, 0, SCALE))
    leaves: list[tuple[_Corners, int]] = []
    stack: list[tuple[_Corners, int]] = [(root, 0)]
    at = 0
    while stack:  # depth first, as serialised
        corners, depth = stack.pop()
        if at >= len(codes) or depth > DEPTH:
            problem = "is truncated" if at >= len(codes) else f"is deeper than {DEPTH} levels"
            raise InputError(path, f"a paint string {problem} ({text[:40]!r})", FIX)
        code = codes[at]
        at += 1
        split = code & 0b11
        if split == 0:
            state = code >> 2
            if state == 3:
                if at >= len(codes):
                    raise InputError(path, f"a paint string is truncated ({text[:40]!r})", FIX)
                state, at = codes[at] + 3, at + 1
            leaves.append((corners, state))
            continue
        children = _children(corners, split, code >> 2)
        # Children were written last first; the stack pops the last pushed first.
        stack.extend((child, depth + 1) for child in children)
    return leaves


def _children(corners: _Corners, split: int, special: int) -> list[_Corners]:
    """Children of a split node, in the slicer's order (see the module docstring)."""
    v0, v1, v2 = (corners[(special + k) % 3] for k in range(3))

    def mid(a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[int, int, int]:
        return (a[0] + b[0]) >> 1, (a[1] + b[1]) >> 1, (a[2] + b[2]) >> 1

    if split == 1:
        m12 = mid(v2, v1)
        return [(v0, v1, m12), (m12, v2, v0)]
    m01, m02 = mid(v1, v0), mid(v0, v2)
    if split == 2:
        return [(v0, m01, m02), (m01, v1, m02), (v1, v2, m02)]
    m12 = mid(v2, v1)
    return [(v0, m01, m02), (m01, v1, m12), (m12, v2, m02), (m01, m12, m02)]


def split_painted(
    path: Path, vertices: NDArray[np.float64], faces: NDArray[np.int64], paint: list[str]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Split every painted triangle into its leaves and close the T-junctions.

    Parameters
    ----------
    path : Path
        The model, for messages.
    vertices : (V, 3) float64
        Vertex positions.
    faces : (F, 3) int64
        Triangles, in the order of ``paint``.
    paint : list of str
        Paint string of each triangle (``""``: unpainted).

    Returns
    -------
    vertices : (V', 3) float64
    faces : (F', 3) int64
        Same orientation as the input triangles.
    state : (F',) int64
        Paint state of each new face (0: unpainted).
    source : (F',) int64
        Input triangle of each new face.
    """
    leaf_face, leaf_bary, leaf_state = [], [], []
    whole = ((SCALE, 0, 0), (0, SCALE, 0), (0, 0, SCALE))
    for face, text in enumerate(paint):  # parsing: one string per triangle
        leaves = decode(path, text) if text else [(whole, 0)]
        leaf_face += [face] * len(leaves)
        leaf_bary += [corners for corners, _ in leaves]
        leaf_state += [state for _, state in leaves]
    owner = np.array(leaf_face, dtype=np.int64)
    bary = np.array(leaf_bary, dtype=np.int64).reshape(-1, 3, 3)  # (L, corner, weight)
    state = np.array(leaf_state, dtype=np.int64)
    # Input vertices merged by exact position, so that shared edges get one key.
    unique, canonical = np.unique(vertices, axis=0, return_inverse=True)
    ids = canonical.reshape(-1)[faces]  # (F, 3)

    corner_keys = _keys(ids, np.repeat(owner, 3), bary.reshape(-1, 3)).reshape(-1, 3, 4)
    known = np.unique(corner_keys.reshape(-1, 4), axis=0)
    # Every leaf edge, as (leaf, start bary, end bary), split while its midpoint is a corner.
    start = bary.reshape(-1, 3)
    end = np.roll(bary, -1, axis=1).reshape(-1, 3)
    leaf = np.repeat(np.arange(len(bary)), 3)
    edge = np.tile(np.arange(3), len(bary))
    final = []
    while len(leaf):  # at most DEPTH rounds
        total = start + end
        even = (total % 2 == 0).all(axis=1)
        middle = total // 2
        hit = even & _member(_keys(ids, owner[leaf], middle), known)
        final.append((leaf[~hit], edge[~hit], start[~hit], end[~hit]))
        leaf, edge = np.repeat(leaf[hit], 2), np.repeat(edge[hit], 2)
        pairs = np.stack([start[hit], middle[hit], middle[hit], end[hit]], axis=1)
        start, end = pairs[:, 0::2].reshape(-1, 3), pairs[:, 1::2].reshape(-1, 3)
    f_leaf, f_edge, f_start, f_end = (np.concatenate(p) for p in zip(*final, strict=True))
    # Position of every distinct key, and the vertex index of each segment end.
    seg_keys = _keys(ids, owner[f_leaf], f_start)
    table, index = np.unique(seg_keys, axis=0, return_inverse=True)
    index = index.reshape(-1)
    first = np.zeros(len(table), dtype=np.int64)
    first[index] = np.arange(len(index))
    tri = unique[ids[owner[f_leaf[first]]]]  # (K, 3 corners, 3)
    weights = f_start[first] / SCALE
    positions = np.einsum("kc,kcd->kd", weights, tri)
    end_index = _lookup(table, _keys(ids, owner[f_leaf], f_end))
    counts = np.bincount(f_leaf, minlength=len(bary))
    plain = counts[f_leaf] == 3
    # Plain leaves keep their triangle (segments of one leaf in edge order 0, 1, 2).
    order = np.lexsort((f_edge, f_leaf))
    plain_ordered = order[plain[order]]
    plain_faces = index[plain_ordered].reshape(-1, 3)
    plain_leaf = f_leaf[plain_ordered].reshape(-1, 3)[:, 0]
    # Leaves with T-junctions: a fan from the centroid over each boundary segment.
    fanned = np.flatnonzero(counts > 3)
    centre_of = np.full(len(bary), -1, dtype=np.int64)
    centre_of[fanned] = len(table) + np.arange(len(fanned))
    centroid = _centroids(bary, fanned, unique[ids[owner[fanned]]])
    fan = ~plain
    fan_faces = np.stack([index[fan], end_index[fan], centre_of[f_leaf[fan]]], axis=1)
    out_faces = np.concatenate([plain_faces, fan_faces])
    out_leaf = np.concatenate([plain_leaf, f_leaf[fan]])
    out_vertices = np.concatenate([positions, centroid])
    return out_vertices, out_faces, state[out_leaf], owner[out_leaf]


def _centroids(
    bary: NDArray[np.int64], leaves: NDArray[np.int64], triangles: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Centroid positions ``(n, 3)`` of the given leaves (``triangles``: their input faces)."""
    weights = bary[leaves].mean(axis=1) / SCALE  # (n, 3): mean of the corners' weights
    centroid: NDArray[np.float64] = np.einsum("nc,ncd->nd", weights, triangles)
    return centroid


def _keys(
    ids: NDArray[np.int64], face: NDArray[np.int64], bary: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Identity ``(n, 4) int64`` of points given by input face and barycentric weights.

    ``(0, vertex, 0, 0)`` for an input vertex, ``(1, a, b, weight of b)`` for a point of
    the input edge ``a < b``, ``(2, face, w1, w2)`` for a point inside an input face.
    """
    corner = ids[face]  # (n, 3) canonical vertex ids
    nonzero = bary != 0
    count = nonzero.sum(axis=1)
    keys = np.zeros((len(face), 4), dtype=np.int64)
    single = count == 1
    keys[single, 1] = corner[single][nonzero[single]]
    double = count == 2
    if double.any():
        pick = np.argsort(~nonzero[double], axis=1, kind="stable")[:, :2]  # the two corners
        rows = np.arange(int(double.sum()))[:, None]
        vid = corner[double][rows, pick]
        weight = bary[double][rows, pick]
        swap = vid[:, 0] > vid[:, 1]
        vid[swap] = vid[swap][:, ::-1]
        weight[swap] = weight[swap][:, ::-1]
        ones = np.ones(len(vid), np.int64)
        keys[double] = np.stack([ones, vid[:, 0], vid[:, 1], weight[:, 1]], axis=1)
    triple = count == 3
    keys[triple] = np.stack(
        [np.full(int(triple.sum()), 2), face[triple], bary[triple, 1], bary[triple, 2]], axis=1
    )
    return keys


def _member(keys: NDArray[np.int64], table: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Whether each row of ``keys`` is a row of the sorted unique ``table``."""
    both = np.concatenate([table, keys])
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    return np.isin(inverse[len(table) :], inverse[: len(table)])


def _lookup(table: NDArray[np.int64], keys: NDArray[np.int64]) -> NDArray[np.int64]:
    """Row of the sorted unique ``table`` equal to each row of ``keys`` (all present)."""
    both = np.concatenate([table, keys])
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    where = np.empty(inverse[: len(table)].max() + 1, dtype=np.int64)
    where[inverse[: len(table)]] = np.arange(len(table))
    looked: NDArray[np.int64] = where[inverse[len(table) :]]
    return looked
