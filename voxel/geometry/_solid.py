"""The solid of any triangle soup on a voxel grid: inside where the winding number is >= 1/2.

For a closed, consistently oriented mesh the exact row crossings of
:mod:`shellvox.voxel.geometry._winding` give every voxel centre's winding number, an
integer. An open, non-manifold or overlapping soup has the generalised winding number
``w`` [1]_ instead, fractional near its holes. It is computed here without evaluating
``w`` at every voxel, from one fact: across a triangle ``w`` jumps by exactly the row
crossings' ``+-1``, so along a row

    w(x) = R(x) + D(x),

``R`` the integer count of signed crossings from the row's start (the row kernel,
unchanged) and ``D`` smooth except at the soup's *boundary curves*, the edges whose faces
do not cancel (holes' rims, non-manifold and misoriented edges), and across their
*shadows*, the sheets a boundary curve sweeps along +x: a row through a shadow crosses
the faces beyond a rim once more or once less than its neighbours, so its ``R`` differs
by 1 from theirs from the rim to the row's end while ``w`` does not, and ``D`` jumps by
1 there. ``D`` is 0 for a closed oriented mesh. So ``w`` is sampled (by
:class:`WindingTree`, the fast winding number) only on a coarse lattice of voxel centres,
``D`` is interpolated trilinearly to every voxel, and ``w`` itself is evaluated where that
could decide wrong: every voxel of a lattice cell that a boundary curve passes near or
whose ``D`` varies by more than :data:`SMOOTH_RANGE`, and every voxel whose interpolated
``w`` lies within :data:`MARGIN` of 1/2. In the cells a shadow may pass through (next to a
rim in ``y`` and ``z``, beyond it along x: a shadow can pass between a cell's corners near
the extremes of a rim seen along x, and leave them all on one side), ``D`` is sampled on
every row at the lattice's x and interpolated along x only.

References
----------
.. [1] A. Jacobson, L. Kavan, O. Sorkine-Hornung, "Robust inside-outside segmentation
   using generalized winding numbers", ACM TOG 32(4), 2013.
.. [2] G. Barill, N. Dickson, R. Schmidt, D. I. W. Levin, A. Jacobson, "Fast winding
   numbers for soups and clouds", ACM TOG 37(4), 2018.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.geometry._fast_winding import WindingTree
from shellvox.voxel.geometry._winding import winding_slab
from shellvox.voxel.grid import GridSpec

#: Spacing of the lattice where ``w`` is sampled (mm, about; whole voxels per axis).
LATTICE_MM = 0.5
#: A lattice cell whose corners' ``D`` differ by more than this is evaluated voxel by voxel.
SMOOTH_RANGE = 0.05
#: Voxels whose interpolated ``w`` lies this close to 1/2 are evaluated exactly.
MARGIN = 0.05


class SoupSolid(NamedTuple):
    """A triangle soup prepared for the inside test of any slab.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        The soup, counter-clockwise seen from outside where it has an outside.
    tree : WindingTree
        Its fast winding numbers.
    rim_points : (P, 3) float64, mm
        Points along its boundary curves, at most half a lattice step apart (none for a
        closed oriented mesh).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    tree: WindingTree
    rim_points: NDArray[np.float64]


class SolidSlab(NamedTuple):
    """The inside of a soup in rows ``z_start <= z < z_stop``.

    Attributes
    ----------
    inside : (Zs, Y, X) bool
        Voxel centres where the generalised winding number is at least 1/2.
    n_sampled : int
        Points of the lattice where ``w`` was evaluated.
    n_exact : int
        Voxel centres where ``w`` was evaluated itself.
    """

    inside: NDArray[np.bool_]
    n_sampled: int
    n_exact: int


def boundary_edges(faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """Return the edges whose faces do not cancel: the boundary curves of the soup.

    An edge used as ``a -> b`` by ``m`` faces and ``b -> a`` by ``n`` faces is on a
    boundary curve where ``m != n``: a hole's rim (1, 0), a non-manifold edge (2, 1) or
    a misoriented one (2, 0).

    Parameters
    ----------
    faces : (F, 3) int64

    Returns
    -------
    (B, 2) int64
        Vertex pairs, ``a < b``.

    Examples
    --------
    >>> boundary_edges(np.array([[0, 1, 2], [0, 2, 3]])).tolist()  # a square's rim
    [[0, 1], [0, 3], [1, 2], [2, 3]]
    """
    faces = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    sign = np.where(directed[:, 0] < directed[:, 1], 1, -1)
    edges = np.sort(directed, axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    net = np.bincount(inverse.reshape(-1), weights=sign, minlength=len(unique))
    rims: NDArray[np.int64] = unique[net != 0]
    return rims


def soup_solid(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, lattice_mm: float = LATTICE_MM
) -> SoupSolid:
    """Prepare a soup for :func:`solid_slab`: its tree and points along its rims.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Vertices merged by position, so that faces sharing an edge share its vertices.
    lattice_mm : float, mm
        The lattice step of :func:`solid_slab`; rim points are at most half of it apart.

    Returns
    -------
    SoupSolid
    """
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    rims = boundary_edges(faces)
    start, stop = vertices[rims[:, 0]], vertices[rims[:, 1]]
    steps = np.maximum(
        np.ceil(np.linalg.norm(stop - start, axis=1) / (0.5 * lattice_mm)).astype(np.int64), 1
    )
    edge = np.repeat(np.arange(len(rims)), steps + 1)
    first = np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    t = (np.arange(len(edge)) - first) / steps[edge]
    points = start[edge] + t[:, None] * (stop - start)[edge]
    return SoupSolid(vertices, faces, WindingTree.build(vertices, faces), points)


class Visibility(NamedTuple):
    """Which faces of a soup lie on its solid's boundary.

    Attributes
    ----------
    visible : (F,) bool
        At least one sample of the face is on the boundary.
    partly : (F,) bool
        Visible, but some sample is not (a face that crosses another part: its buried
        piece must not decide a voxel's depth).
    """

    visible: NDArray[np.bool_]
    partly: NDArray[np.bool_]


def visible_faces(solid: SoupSolid, *, side_mm: float | None = None) -> Visibility:
    """Return which faces of a soup lie on its solid's boundary, wholly or in part.

    A face is visible where the solid is on one side of it and not on the other: at its
    centroid or at one of the three points halfway from there to its corners, the winding
    number is at least 1/2 on exactly one side (``side_mm`` off the face along its
    normal). Faces buried inside the solid (a part pushed into another, a duplicated
    wall, an eye inside a head) and faces outside it (a sheet that encloses nothing) are
    not.

    Parameters
    ----------
    solid : SoupSolid
    side_mm : float, mm, optional
        How far off the face each side is sampled; default ``1e-5`` of the soup's
        bounding-box diagonal.

    Returns
    -------
    Visibility
    """
    corners = solid.vertices[solid.faces]  # (F, 3, 3)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    if side_mm is None:
        side_mm = 1e-5 * float(np.linalg.norm(np.ptp(solid.vertices, axis=0)))
    centroid = corners.mean(axis=1)
    samples = np.concatenate([centroid[:, None], 0.5 * (centroid[:, None] + corners)], axis=1)
    points = samples.reshape(-1, 3)
    offset = np.repeat(normal, 4, axis=0) * side_mm
    outer = solid.tree.evaluate(points + offset) >= 0.5
    inner = solid.tree.evaluate(points - offset) >= 0.5
    sides = (outer != inner).reshape(-1, 4) & (length > 0)
    visible = sides.any(axis=1)
    return Visibility(visible, visible & ~sides.all(axis=1))


def solid_slab(
    solid: SoupSolid,
    grid: GridSpec,
    z_start: int,
    z_stop: int,
    *,
    lattice_mm: float = LATTICE_MM,
) -> SolidSlab:
    """Return which voxel centres of a slab lie in the soup's solid (``w >= 1/2``).

    Parameters
    ----------
    solid : SoupSolid
        From :func:`soup_solid`, with the same `lattice_mm`.
    grid : GridSpec
        The voxel grid.
    z_start, z_stop : int
        Rows of the slab, ``0 <= z_start < z_stop <= Z``.
    lattice_mm : float, mm
        Spacing of the lattice where ``w`` is sampled (rounded to whole voxels per axis).

    Returns
    -------
    SolidSlab
        The same inside as ``w >= 1/2`` at every voxel centre, where the interpolation
        is trusted only in smooth cells and away from 1/2 (see the module).
    """
    rows = winding_slab(solid.vertices, solid.faces, grid, z_start, z_stop).winding
    n_zs, n_y, n_x = rows.shape
    voxel = np.asarray(grid.voxel_mm, dtype=np.float64)  # (x, y, z)
    stride = np.maximum(np.round(lattice_mm / voxel[::-1]).astype(np.int64), 1)  # (z, y, x)
    axes = [_lattice(n, int(s)) for n, s in zip((n_zs, n_y, n_x), stride, strict=True)]
    lz, ly, lx = np.meshgrid(*axes, indexing="ij")
    index = np.stack([lz.reshape(-1) + z_start, ly.reshape(-1), lx.reshape(-1)], axis=1)
    sampled = solid.tree.evaluate(grid.index_to_world(index)).reshape(lz.shape)
    smooth = sampled - rows[np.ix_(*axes)]
    # w = R + D, D interpolated from the lattice, one axis at a time
    cells, weights = zip(
        *(_cell_of(n, lattice) for n, lattice in zip((n_zs, n_y, n_x), axes, strict=True)),
        strict=True,
    )
    interpolated = smooth
    for axis in range(3):
        below = np.take(interpolated, cells[axis], axis=axis)
        above = np.take(interpolated, cells[axis] + 1, axis=axis)
        shape = [1, 1, 1]
        shape[axis] = -1
        t = weights[axis].reshape(shape)
        interpolated = below + (above - below) * t
    winding = rows + interpolated
    rough, shadow = _rough_cells(smooth, solid.rim_points, grid, axes, z_start)
    unsure = rough[np.ix_(*cells)]
    n_sampled = int(sampled.size)
    in_shadow = np.flatnonzero(shadow[np.ix_(*cells)])
    if len(in_shadow):  # D sampled on every row at the lattice's x, interpolated along x
        z, y, x = np.unravel_index(in_shadow, rows.shape)
        cell_x = cells[2][x]
        ends = np.concatenate(
            [np.ravel_multi_index((z, y, axes[2][cell_x + k]), rows.shape) for k in (0, 1)]
        )
        nodes, at = np.unique(ends, return_inverse=True)
        where = np.stack(np.unravel_index(nodes, rows.shape), axis=1)
        where[:, 0] += z_start
        along = solid.tree.evaluate(grid.index_to_world(where)) - rows.reshape(-1)[nodes]
        first, last = along[at[: len(x)]], along[at[len(x) :]]
        winding.reshape(-1)[in_shadow] = rows.reshape(-1)[in_shadow] + (
            first + (last - first) * weights[2][x]
        )
        unsure.reshape(-1)[in_shadow[np.abs(last - first) > SMOOTH_RANGE]] = True
        n_sampled += len(nodes)
    unsure |= np.abs(winding - 0.5) < MARGIN
    exact = np.flatnonzero(unsure)
    if len(exact):
        where = np.stack(np.unravel_index(exact, rows.shape), axis=1)
        where[:, 0] += z_start
        winding.reshape(-1)[exact] = solid.tree.evaluate(grid.index_to_world(where))
    return SolidSlab(winding >= 0.5, n_sampled, len(exact))


def _lattice(n: int, stride: int) -> NDArray[np.int64]:
    """Lattice indices along an axis of `n` voxels: every `stride`-th and the last."""
    return np.unique(np.append(np.arange(0, n, stride), n - 1))


def _cell_of(n: int, lattice: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Each voxel's lattice cell along an axis and its position in it (0..1)."""
    voxels = np.arange(n)
    if len(lattice) == 1:
        return np.zeros(n, dtype=np.int64), np.zeros(n)
    cell = np.clip(np.searchsorted(lattice, voxels, side="right") - 1, 0, len(lattice) - 2)
    span = (lattice[cell + 1] - lattice[cell]).astype(np.float64)
    return cell, (voxels - lattice[cell]) / span


def _rough_cells(
    smooth: NDArray[np.float64],
    rim_points: NDArray[np.float64],
    grid: GridSpec,
    axes: list[NDArray[np.int64]],
    z_start: int,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Lattice cells ``(Lz - 1, Ly - 1, Lx - 1)`` where ``D`` may not be smooth.

    Returns
    -------
    rough : (Lz - 1, Ly - 1, Lx - 1) bool
        Cells whose corners' ``D`` differ by more than :data:`SMOOTH_RANGE`, or where a
        rim point lies in it or in a cell next to it (near a boundary curve ``D`` changes
        over distances shorter than a cell): evaluated voxel by voxel.
    shadow : (Lz - 1, Ly - 1, Lx - 1) bool
        The other cells next to a rim point's cell in ``y`` and ``z`` and beyond it along
        +x: a rim's shadow may pass between their corners, where ``D`` jumps by 1 from
        row to row, but along a row ``D`` stays smooth.
    """
    shape = tuple(max(len(a) - 1, 1) for a in axes)
    if min(len(a) for a in axes) < 2:
        return np.ones(shape, dtype=bool), np.zeros(shape, dtype=bool)
    corners = [
        smooth[dz : dz + shape[0], dy : dy + shape[1], dx : dx + shape[2]]
        for dz in (0, 1)
        for dy in (0, 1)
        for dx in (0, 1)
    ]
    rough: NDArray[np.bool_] = (np.max(corners, axis=0) - np.min(corners, axis=0)) > SMOOTH_RANGE
    if len(rim_points):
        index = grid.world_to_index(rim_points)  # (z, y, x), fractional
        index[:, 0] -= z_start
        cell = np.stack(
            [np.searchsorted(a, index[:, k], side="right") - 1 for k, a in enumerate(axes)],
            axis=1,
        )
        near = np.zeros(shape, dtype=bool)
        for dz in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    at = cell + np.array((dz, dy, dx))
                    keep = np.all((at >= 0) & (at < shape), axis=1)
                    near[tuple(at[keep].T)] = True
        rough |= near
        return rough, np.logical_or.accumulate(near, axis=2) & ~rough
    return rough, np.zeros(shape, dtype=bool)
