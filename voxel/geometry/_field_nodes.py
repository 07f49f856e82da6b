"""The voxel centres where a build keeps the layer field for its shell meshes.

A build with distance layers whose ``field`` shells are meshed too keeps, in every slab,
what the voxels' scan (:mod:`shellvox.voxel.geometry._distance_scan`) found at every few
voxel centres (:class:`NodeLattice`): inside or not, the exact nearest face and its squared
distance (:class:`FieldNodes`). :class:`shellvox.offset.field.layer_field.LatticeMesher`
marches those nodes into the shells, so the layer field is scanned once.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.grid import GridSpec


class NodeLattice(NamedTuple):
    """The voxel centres where a slab keeps the layer field for the shell meshes.

    Attributes
    ----------
    stride_zyx : (3,) int
        Every ``stride``-th voxel centre on each axis, from voxel ``(0, 0, 0)``.
    beyond_mm : float, mm
        How far beyond the deepest depth the nodes need their exact nearest face (two
        node steps: no edge of the march that crosses a layer reaches farther).
    """

    stride_zyx: tuple[int, int, int]
    beyond_mm: float

    def planes(self, z_start: int, z_stop: int) -> range:
        """Return the voxel rows of the node planes in rows ``z_start..z_stop``."""
        step = self.stride_zyx[0]
        return range(-(-z_start // step) * step, z_stop, step)


class FieldNodes(NamedTuple):
    """The scan's answer at the nodes of a :class:`NodeLattice` in one slab.

    Attributes
    ----------
    first : int
        Node plane of the first row (voxel row ``first * stride_z``).
    inside : (P, Yn, Xn) bool
        Nodes inside the surface.
    squared : (P, Yn, Xn) float64, mm^2
        Squared distance to the nearest face where ``face >= 0``.
    face : (P, Yn, Xn) int32
        Nearest face (lowest index among ties), -1 beyond the reach.
    """

    first: int
    inside: NDArray[np.bool_]
    squared: NDArray[np.float64]
    face: NDArray[np.int32]


def node_lattice(voxels: GridSpec, step_mm: float) -> NodeLattice:
    """Return the voxel centres a build meshes its shells from: about `step_mm` apart.

    Every ``round(step_mm / voxel)``-th voxel centre on each axis (at least every one);
    the J750's 42.3 x 84.6 x 27 um voxels at 0.1 mm give nodes 84.6 x 84.6 x 108 um
    apart.

    >>> node_lattice(GridSpec((0.0, 0, 0), (0.0423, 0.0846, 0.027), (9, 9, 9)), 0.1)
    NodeLattice(stride_zyx=(4, 1, 2), beyond_mm=0.216)
    """
    if not (math.isfinite(step_mm) and step_mm > 0):
        raise ValueError(f"step_mm must be positive and finite, got {step_mm}")
    voxel_zyx = voxels.voxel_mm[::-1]
    stride = tuple(max(1, round(step_mm / v)) for v in voxel_zyx)
    largest = max(n * v for n, v in zip(stride, voxel_zyx, strict=True))
    return NodeLattice((stride[0], stride[1], stride[2]), round(2.0 * largest, 12))
