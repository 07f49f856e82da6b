"""Generalised winding numbers of a triangle soup, fast: a tree of far-field expansions.

The generalised winding number [1]_ of a point ``p`` with respect to triangles ``t`` is

    w(p) = 1 / (4 pi) * sum_t Omega_t(p),

the signed solid angles ``Omega_t`` of the triangles seen from ``p`` over the whole
sphere: 1 inside a closed outward-oriented surface, 0 outside, ``k`` inside ``k`` nested
or overlapping closed parts, -1 inside an inside-out one, and in between near holes
(inside where it is at least 1/2). It needs no closed, manifold or consistently joined mesh.

Summing every triangle for every point costs ``F`` solid angles per point. The tree
method of Barill et al. [2]_ groups the triangles in a tree and, for a node far from the
point (``|p - c| > beta * r``, ``c`` the node's area-weighted centroid and ``r`` the
largest distance from ``c`` to a corner of its triangles), replaces the node's solid
angles by the Taylor expansion of the dipole kernel about ``c``, to the second order:

- order 0: the dipole ``N = sum a_t n_t`` (area times unit normal);
- order 1: ``M_ij = sum n_ti integral_t (x - c)_j dA``;
- order 2: ``T_ijk = sum n_ti integral_t (x - c)_j (x - c)_k dA`` (exact triangle
  moments);

near nodes are opened, and the triangles of a near leaf are summed exactly with the solid
angle of Van Oosterom and Strackee [3]_ (its ``atan2`` form, signed, robust at grazing
angles). libigl's ``fast_winding_number`` on triangles (the Houdini SDK's
``UT_SolidAngle``, in single precision) is the same method with the same defaults
(order 2, ``beta = 2``).

The tree (:class:`WindingTree`) is built in numpy, whole-array: a balanced binary tree
over the triangles by median splits of their centroids along each node's longest side
(one sort per level), its leaves holding half :data:`LEAF_FACES` to :data:`LEAF_FACES`
triangles, the expansion terms summed at the leaves and shifted up to the parents level
by level, the radii exact. :meth:`WindingTree.evaluate` walks it for every point in one
compiled loop with an explicit stack (:func:`shellvox.voxel._compiled.kernel`, no GIL),
batches of points side by side in up to :data:`MAX_THREADS` threads.

References
----------
.. [1] A. Jacobson, L. Kavan, O. Sorkine-Hornung, "Robust inside-outside segmentation
   using generalized winding numbers", ACM TOG 32(4) (SIGGRAPH 2013).
.. [2] G. Barill, N. Dickson, R. Schmidt, D. I. W. Levin, A. Jacobson, "Fast winding
   numbers for soups and clouds", ACM TOG 37(4) (SIGGRAPH 2018).
.. [3] A. Van Oosterom, J. Strackee, "The solid angle of a plane triangle", IEEE
   Transactions on Biomedical Engineering 30(2), 1983.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

#: Triangles in a leaf at most (a leaf holds between half this and this many).
LEAF_FACES = 4
#: Threads evaluating batches of points at most (the compiled walk releases the GIL).
MAX_THREADS = 2
#: Points walked by one call of the compiled loop (one task of the thread pool).
POINTS_PER_TASK = 1 << 15
#: Barill et al.'s accuracy parameter: a node is far from a point beyond ``beta`` radii.
BETA = 2.0
#: The columns of :attr:`WindingTree.nodes`: the node's centre and squared radius, then
#: the expansion terms, symmetric parts only (``Mxy_yx`` is ``M[x, y] + M[y, x]``,
#: ``Lx`` is ``sum_i 2 T[i, i, x] + T[x, i, i]``, ``Cxxy`` the sum of ``T`` over the
#: orderings of ``x, x, y``).
NODE_COLUMNS = (
    "cx", "cy", "cz", "radius2",
    "Nx", "Ny", "Nz",
    "Mxx", "Myy", "Mzz", "Mxy_yx", "Mxz_zx", "Myz_zy",
    "Lx", "Ly", "Lz",
    "Cxxx", "Cyyy", "Czzz", "Cxxy", "Cxxz", "Cxyy", "Cyyz", "Cxzz", "Cyzz", "Cxyz",
)  # fmt: skip


class WindingTree(NamedTuple):
    """A triangle soup prepared for fast winding numbers: a balanced tree of expansions.

    Nodes are numbered as a heap (node ``n`` has children ``2n + 1`` and ``2n + 2``);
    the ``2 ** depth`` leaves are the last nodes, leaf ``k`` (node ``2 ** depth - 1 + k``)
    holding the triangles ``leaf_bounds[k]:leaf_bounds[k + 1]`` of :attr:`triangles`.

    Attributes
    ----------
    triangles : (F, 3, 3) float64, mm
        The corners of each triangle, in tree order.
    leaf_bounds : (2 ** depth + 1,) int64
        Where each leaf's triangles start and end.
    nodes : (2 ** (depth + 1) - 1, 26) float64
        Per node, the columns :data:`NODE_COLUMNS`: the area-weighted centroid ``c`` of
        its triangles (mm; the middle of their centroids where their area is zero), the
        squared largest distance from ``c`` to a corner of them (mm^2), and the Taylor
        terms about ``c`` of Barill et al.: order 0 the dipole ``N = sum a_t n_t``
        (mm^2), order 1 ``M[i, j] = sum n_ti integral_t (x - c)_j dA`` (mm^3), order 2
        ``T[i, j, k] = sum n_ti integral_t (x - c)_j (x - c)_k dA`` (mm^4), ``n_t`` the
        unit normal.
    depth : int
        Levels below the root (0: the root is the only leaf).
    """

    triangles: NDArray[np.float64]
    leaf_bounds: NDArray[np.int64]
    nodes: NDArray[np.float64]
    depth: int

    @classmethod
    def build(cls, vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> WindingTree:
        """Build the tree of a triangle soup.

        Parameters
        ----------
        vertices : (V, 3) float64, mm
            Vertex positions.
        faces : (F, 3) int64
            Triangles (any orientation; open, overlapping or duplicated), ``F >= 1``.

        Returns
        -------
        WindingTree
        """
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertices must be (V, 3), got shape {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise ValueError(f"faces must be (F, 3) with F >= 1, got shape {faces.shape}")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise ValueError(f"faces must index the vertices 0..{len(vertices) - 1}")
        return _build(vertices[faces])

    def evaluate(
        self, points_mm: NDArray[np.float64], *, beta: float = BETA, threads: int | None = None
    ) -> NDArray[np.float64]:
        """Return the generalised winding number of each point.

        The points are walked in the order of their Morton codes (neighbours one after
        the other share the nodes they open), in batches of :data:`POINTS_PER_TASK`.

        Parameters
        ----------
        points_mm : (Q, 3) float64, mm
            Query points ``(x, y, z)``.
        beta : float, optional
            Far-field distance in node radii (Barill et al.'s ``beta``); larger is more
            accurate and slower; 0 sums every triangle exactly.
        threads : int, optional
            Threads walking the batches (default: this process's CPUs, at most
            :data:`MAX_THREADS`).

        Returns
        -------
        (Q,) float64
            The winding numbers (1 inside a closed outward-oriented surface, 0 outside).
        """
        points = np.asarray(points_mm, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points_mm must be (Q, 3), got shape {points.shape}")
        if not (beta >= 0.0 and math.isfinite(beta)):
            raise ValueError(f"beta must be a finite number >= 0, got {beta}")
        order = _morton_order(points)
        walked = np.ascontiguousarray(points[order])
        winding = np.zeros(len(points), dtype=np.float64)
        # a node is far where |p - c|^2 > beta^2 r^2; beta = 0 opens every node
        beta2 = beta * beta if beta > 0 else math.inf
        spans = [
            (start, min(start + POINTS_PER_TASK, len(points)))
            for start in range(0, len(points), POINTS_PER_TASK)
        ]

        def walk(span: tuple[int, int]) -> None:
            _walk(
                walked, winding, span[0], span[1], self.triangles, self.leaf_bounds,
                self.nodes, beta2, self.depth,
            )  # fmt: skip

        count = _threads() if threads is None else max(1, int(threads))
        if count == 1 or len(spans) <= 1:
            for span in spans:
                walk(span)
        else:
            with ThreadPoolExecutor(count, thread_name_prefix="shellvox-winding") as pool:
                list(pool.map(walk, spans))
        result = np.empty_like(winding)
        result[order] = winding
        return result


def fast_winding_numbers(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    points_mm: NDArray[np.float64],
    *,
    beta: float = BETA,
) -> NDArray[np.float64]:
    """Return the generalised winding number of points with respect to a triangle soup.

    The tree method of Barill et al. [2]_ (see the module's notes); for many batches of
    points on one mesh, build a :class:`WindingTree` once and call its
    :meth:`~WindingTree.evaluate`.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
        Vertex positions.
    faces : (F, 3) int64
        Triangles, counter-clockwise seen from outside (open, overlapping, duplicated
        and inside-out parts are allowed); none: every winding number is 0.
    points_mm : (Q, 3) float64, mm
        Query points ``(x, y, z)``.
    beta : float, optional
        Far-field distance in node radii; larger is more accurate and slower; 0 sums
        every triangle exactly.

    Returns
    -------
    (Q,) float64
        1 inside a closed outward-oriented surface, 0 outside, the sum over overlapping
        parts, fractional near holes (inside where it is at least 1/2).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> q = np.array([[0.25, 0.25, 0.25], [5.0, 5.0, 5.0]])
    >>> (fast_winding_numbers(v, f, q).round(6) + 0.0).tolist()  # + 0.0: no -0.0
    [1.0, 0.0]
    >>> (fast_winding_numbers(v, f[:, ::-1], q).round(6) + 0.0).tolist()  # inside out
    [-1.0, 0.0]
    """
    faces = np.asarray(faces, dtype=np.int64)
    if faces.size == 0:
        return np.zeros(len(np.asarray(points_mm)), dtype=np.float64)
    return WindingTree.build(vertices, faces).evaluate(points_mm, beta=beta)


def _threads() -> int:
    """Return the walk's threads: this process's CPUs, at most :data:`MAX_THREADS`."""
    return max(1, min(MAX_THREADS, len(os.sched_getaffinity(0))))


def _morton_order(points: NDArray[np.float64]) -> NDArray[np.int64]:
    """Return the order ``(Q,) int64`` of `points` along a Z curve (2^10 cells a side)."""
    if len(points) < 2:
        return np.arange(len(points), dtype=np.int64)
    finite = np.where(np.isfinite(points), points, 0.0)
    low, span = finite.min(axis=0), np.ptp(finite, axis=0)
    cells = (finite - low) * (1023.0 / np.where(span > 0, span, 1.0))
    code = np.zeros(len(points), dtype=np.int64)
    for axis in range(3):
        bits = cells[:, axis].astype(np.int64)
        for shift, mask in ((16, 0x30000FF), (8, 0x300F00F), (4, 0x30C30C3), (2, 0x9249249)):
            bits = (bits | (bits << shift)) & mask
        code |= bits << axis
    order: NDArray[np.int64] = np.argsort(code)
    return order


def _build(triangles: NDArray[np.float64]) -> WindingTree:
    """Return the tree of `triangles` ``(F, 3, 3)`` mm (see :meth:`WindingTree.build`)."""
    n_faces = len(triangles)
    depth = math.ceil(math.log2(n_faces / LEAF_FACES)) if n_faces > LEAF_FACES else 0
    n_leaves = 1 << depth
    bounds = np.arange(n_leaves + 1, dtype=np.int64) * n_faces // n_leaves
    centroids = triangles.mean(axis=1)
    order = np.arange(n_faces)
    ordered = centroids
    for level in range(depth):  # median splits: one sort of all the nodes per level
        edges = bounds[:: n_leaves >> level]
        node = np.repeat(np.arange(1 << level), np.diff(edges))
        low = np.minimum.reduceat(ordered, edges[:-1])
        side = np.maximum.reduceat(ordered, edges[:-1]) - low
        axis = np.argmax(side, axis=1)
        key = ordered[np.arange(n_faces), axis[node]] - low[np.arange(len(axis)), axis][node]
        span = side[np.arange(len(axis)), axis]
        # the node's number plus its centroids' place along its longest side, in [0, 1/2]
        key = node + 0.5 * key / np.where(span > 0, span, 1.0)[node]
        split = np.argsort(key)
        ordered, order = ordered[split], order[split]
    triangles = np.ascontiguousarray(triangles[order])
    centroids = centroids[order]
    normals = 0.5 * np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    areas = np.linalg.norm(normals, axis=1)  # normals: area times unit normal, mm^2

    n_nodes = 2 * n_leaves - 1
    centres = np.zeros((n_nodes, 3))
    area = np.zeros(n_nodes)
    dipoles = np.zeros((n_nodes, 3))
    firsts = np.zeros((n_nodes, 3, 3))
    seconds = np.zeros((n_nodes, 3, 3, 3))
    # the leaves: the terms about each leaf's centre, summed over its triangles
    leaves, starts = slice(n_leaves - 1, n_nodes), bounds[:-1]
    area[leaves] = np.add.reduceat(areas, starts)
    weighted = np.add.reduceat(areas[:, None] * centroids, starts)
    middle = np.add.reduceat(centroids, starts) / np.diff(bounds)[:, None]
    centres[leaves] = _centre(weighted, area[leaves], middle)
    leaf_of = np.repeat(np.arange(n_leaves), np.diff(bounds))
    corners = triangles - centres[leaves][leaf_of][:, None, :]  # about the leaf's centre
    offsets = corners.mean(axis=1)
    # integral (x - c)(x - c)^T dA / area, exact on a triangle
    moments = (np.einsum("fkj,fkl->fjl", corners, corners) + 9.0 * _outer(offsets, offsets)) / 12.0
    dipoles[leaves] = np.add.reduceat(normals, starts)
    firsts[leaves] = np.add.reduceat(_outer(normals, offsets), starts)
    seconds[leaves] = np.add.reduceat(normals[:, :, None, None] * moments[:, None], starts)
    for level in range(depth - 1, -1, -1):  # parents from children, shifted to their centre
        parents = np.arange((1 << level) - 1, (2 << level) - 1)
        left, right = 2 * parents + 1, 2 * parents + 2
        area[parents] = area[left] + area[right]
        weighted = area[left, None] * centres[left] + area[right, None] * centres[right]
        centres[parents] = _centre(weighted, area[parents], 0.5 * (centres[left] + centres[right]))
        dipoles[parents] = dipoles[left] + dipoles[right]
        for child in (left, right):
            shift = centres[child] - centres[parents]
            n, m = dipoles[child], firsts[child]
            firsts[parents] += m + _outer(n, shift)
            seconds[parents] += (
                seconds[child]
                + m[:, :, :, None] * shift[:, None, None, :]
                + m[:, :, None, :] * shift[:, None, :, None]
                + n[:, :, None, None] * _outer(shift, shift)[:, None]
            )
    radius2 = np.zeros(n_nodes)
    # exact radii: the farthest corner of each node, |v - c|^2 = |v|^2 - 2 v.c + |c|^2
    # (about the root's centre, so that the terms stay of the size of the mesh)
    about_root = triangles - centres[0]
    squares = np.einsum("fkd,fkd->fk", about_root, about_root)
    for level in range(depth + 1):
        edges = bounds[:: n_leaves >> level]
        nodes = slice((1 << level) - 1, (2 << level) - 1)
        node = np.repeat(np.arange(1 << level), np.diff(edges))
        centre = centres[nodes] - centres[0]
        reach = (squares - 2.0 * np.einsum("fkd,fd->fk", about_root, centre[node])).max(axis=1)
        farthest = np.maximum.reduceat(reach, edges[:-1]) + np.einsum("nd,nd->n", centre, centre)
        radius2[nodes] = np.maximum(farthest, 0.0)
    packed = _pack(centres, radius2, dipoles, firsts, seconds)
    return WindingTree(triangles, bounds, packed, depth)


def _outer(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return the outer products ``(N, 3, 3)`` of the rows of `a` and `b` ``(N, 3)``."""
    product: NDArray[np.float64] = a[:, :, None] * b[:, None, :]
    return product


def _centre(
    weighted: NDArray[np.float64], area: NDArray[np.float64], middle: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return ``weighted / area`` ``(N, 3)``, or `middle` where the area is zero."""
    with np.errstate(divide="ignore", invalid="ignore"):
        centre = weighted / area[:, None]
    result: NDArray[np.float64] = np.where((area > 0)[:, None], centre, middle)
    return result


def _pack(
    centres: NDArray[np.float64],
    radius2: NDArray[np.float64],
    dipoles: NDArray[np.float64],
    firsts: NDArray[np.float64],
    seconds: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Return the rows ``(N, 26)`` of :data:`NODE_COLUMNS` from the full terms."""
    m = firsts
    linear = 2.0 * np.einsum("niij->nj", seconds) + np.einsum("njii->nj", seconds)
    # the cubic form sum T_ijk r_i r_j r_k: one coefficient per monomial
    monomials = ((0, 0, 0), (1, 1, 1), (2, 2, 2), (0, 0, 1), (0, 0, 2), (0, 1, 1), (1, 1, 2),
                 (0, 2, 2), (1, 2, 2), (0, 1, 2))  # fmt: skip
    index = {ijk: column for column, ijk in enumerate(monomials)}
    gather = np.zeros((27, len(monomials)))
    for flat in range(27):  # T[i, j, k] adds to the monomial of its sorted indices
        i, j, k = sorted((flat // 9, flat // 3 % 3, flat % 3))
        gather[flat, index[i, j, k]] = 1.0
    cubic = seconds.reshape(len(seconds), 27) @ gather
    packed = np.column_stack([
        centres, radius2, dipoles,
        m[:, 0, 0], m[:, 1, 1], m[:, 2, 2],
        m[:, 0, 1] + m[:, 1, 0], m[:, 0, 2] + m[:, 2, 0], m[:, 1, 2] + m[:, 2, 1],
        linear, cubic,
    ])  # fmt: skip
    return np.ascontiguousarray(packed)


@kernel(inline="always")
def _solid_angle(
    triangles: NDArray[np.float64], face: int, px: float, py: float, pz: float
) -> float:
    """Signed solid angle of triangle `face` seen from ``p`` (Van Oosterom-Strackee)."""
    ax, ay, az = triangles[face, 0, 0] - px, triangles[face, 0, 1] - py, triangles[face, 0, 2] - pz
    bx, by, bz = triangles[face, 1, 0] - px, triangles[face, 1, 1] - py, triangles[face, 1, 2] - pz
    cx, cy, cz = triangles[face, 2, 0] - px, triangles[face, 2, 1] - py, triangles[face, 2, 2] - pz
    la = math.sqrt(ax * ax + ay * ay + az * az)
    lb = math.sqrt(bx * bx + by * by + bz * bz)
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    div = (
        la * lb * lc
        + (ax * bx + ay * by + az * bz) * lc
        + (bx * cx + by * cy + bz * cz) * la
        + (cx * ax + cy * ay + cz * az) * lb
    )
    angle: float = 2.0 * math.atan2(det, div)
    return angle


@kernel(inline="always")
def _far_field(nodes: NDArray[np.float64], n: int, x: float, y: float, z: float) -> float:
    """Solid angle of node `n` (its row of :data:`NODE_COLUMNS`) seen from ``c - (x, y, z)``."""
    r2 = x * x + y * y + z * z
    inv2 = 1.0 / r2
    inv3 = inv2 / math.sqrt(r2)
    inv5 = inv3 * inv2
    order0 = (nodes[n, 4] * x + nodes[n, 5] * y + nodes[n, 6] * z) * inv3
    trace = nodes[n, 7] + nodes[n, 8] + nodes[n, 9]
    quadratic = (
        nodes[n, 7] * x * x + nodes[n, 8] * y * y + nodes[n, 9] * z * z
        + nodes[n, 10] * x * y + nodes[n, 11] * x * z + nodes[n, 12] * y * z
    )  # fmt: skip
    order1 = trace * inv3 - 3.0 * quadratic * inv5
    linear = nodes[n, 13] * x + nodes[n, 14] * y + nodes[n, 15] * z
    cubic = (
        nodes[n, 16] * x * x * x + nodes[n, 17] * y * y * y + nodes[n, 18] * z * z * z
        + nodes[n, 19] * x * x * y + nodes[n, 20] * x * x * z + nodes[n, 21] * x * y * y
        + nodes[n, 22] * y * y * z + nodes[n, 23] * x * z * z + nodes[n, 24] * y * z * z
        + nodes[n, 25] * x * y * z
    )  # fmt: skip
    order2 = (-1.5 * linear + 7.5 * cubic * inv2) * inv5
    solid_angle: float = order0 + order1 + order2
    return solid_angle


@kernel
def _walk(
    points: NDArray[np.float64],
    out: NDArray[np.float64],
    start: int,
    stop: int,
    triangles: NDArray[np.float64],
    leaf_bounds: NDArray[np.int64],
    nodes: NDArray[np.float64],
    beta2: float,
    depth: int,
) -> None:
    """Write the winding numbers of ``points[start:stop]`` into ``out[start:stop]``.

    Depth first with an explicit stack of the near nodes still to open: a node's children
    are tested as it is opened, the far ones summed by their expansion at once.
    """
    first_leaf = (1 << depth) - 1
    stack = np.empty(depth + 2, dtype=np.int64)  # one waiting sibling per level at most
    for q in range(start, stop):
        px, py, pz = points[q, 0], points[q, 1], points[q, 2]
        total = 0.0
        top = 0
        x, y, z = nodes[0, 0] - px, nodes[0, 1] - py, nodes[0, 2] - pz
        if x * x + y * y + z * z > beta2 * nodes[0, 3]:
            total = _far_field(nodes, 0, x, y, z)
        else:
            stack[0] = 0
            top = 1
        while top > 0:
            top -= 1
            node = stack[top]
            if node >= first_leaf:
                leaf = node - first_leaf
                for face in range(leaf_bounds[leaf], leaf_bounds[leaf + 1]):
                    total += _solid_angle(triangles, face, px, py, pz)
                continue
            for child in range(2 * node + 1, 2 * node + 3):
                x, y, z = nodes[child, 0] - px, nodes[child, 1] - py, nodes[child, 2] - pz
                if x * x + y * y + z * z > beta2 * nodes[child, 3]:
                    total += _far_field(nodes, child, x, y, z)
                else:
                    stack[top] = child
                    top += 1
        out[q] = total / (4.0 * math.pi)
