"""The grid step of the ``field`` shells: the default, and raised where a surface is large.

:func:`automatic_step` is the step of :func:`shellvox.offset.offset_shells` and of the
``shells`` command; :func:`automatic_lattice` the voxel centres a build meshes its shells
from (:class:`shellvox.voxel.geometry._field_nodes.NodeLattice`).
"""

from __future__ import annotations

import math

import numpy as np

from shellvox.voxel.geometry._field_nodes import NodeLattice, node_lattice
from shellvox.voxel.grid import GridSpec

#: Default grid step of the ``field`` shells (``--shell-step``), mm. On spot at 100 mm
#: (93,696 faces, depths 0.5 and 1.5 mm) 0.1 mm gave |d - D| p99 1.3 um and max 25 um before
#: simplification; 0.05 mm halves the error at four times the triangles and eight times the
#: nodes (benchmarks/bench_field_shells.py).
SHELL_STEP_MM = 0.1

#: Marching-tetrahedra triangles of one layer per mm^2 of surface times the step squared
#: (spot at 100 mm: 16.5 M triangles of 19,127 mm^2 at 0.1 mm, 8.6).
TRIANGLES_PER_AREA = 8.7

#: Triangles all layers may have before simplification at the automatic step (about 320
#: bytes each at the peak: 11.5 GB; spot at 100 mm, two layers, 31.6 M, keeps 0.1 mm).
MAX_FIELD_TRIANGLES = 36_000_000

#: Bytes per marching-tetrahedra triangle at the field shells' peak (the marched layers, the
#: simplification's heap and its crossing tests): spot built at 100 mm with shell meshes,
#: 31.5 M triangles, peaked at 10.9 GB in the process that meshes them.
BYTES_PER_FIELD_TRIANGLE = 320

#: Seconds per marching-tetrahedra triangle of the field shells, marching and simplifying
#: (spot built at 100 mm with shell meshes: 31.5 M triangles, 53 s of field and 204 s of
#: simplification).
SECONDS_PER_FIELD_TRIANGLE = 8.2e-6


def field_triangles(area_mm2: float, layers: int, step_mm: float) -> int:
    """Return about how many triangles the field shells march before simplification.

    ``TRIANGLES_PER_AREA`` per mm^2 of surface and layer at a step of 1 mm, over the step
    squared (mm): spot at 100 mm, two layers, a 0.106 mm cell, 29.8 M (31.5 M marched).

    >>> f"{field_triangles(19127.0, 2, 0.1056):.3g}"
    '2.98e+07'
    """
    return int(TRIANGLES_PER_AREA * area_mm2 * layers / step_mm**2)


def lattice_cell_mm(voxels: GridSpec, lattice: NodeLattice) -> float:
    """Return the side of a cube of a lattice's cell volume (mm), its step for the triangles.

    >>> voxels = GridSpec((0.0, 0, 0), (0.0423, 0.0846, 0.027), (9, 9, 9))
    >>> round(lattice_cell_mm(voxels, NodeLattice((4, 1, 3), 0.2)), 4)
    0.1051
    """
    cells = np.asarray(voxels.voxel_mm[::-1], dtype=np.float64) * lattice.stride_zyx
    return float(np.prod(cells) ** (1 / 3))


def automatic_step(area_mm2: float, layers: int) -> float:
    """Return the grid step of the ``field`` shells for a surface (mm).

    ``SHELL_STEP_MM``, raised (to whole hundredths of a mm) where the layers' triangles
    before simplification would pass ``MAX_FIELD_TRIANGLES``; a 120 mm polyhedron of
    53,660 mm^2 with two layers gets 0.17 mm.

    >>> automatic_step(19127.0, 2), automatic_step(53660.0, 2)
    (0.1, 0.17)
    """
    needed = math.sqrt(TRIANGLES_PER_AREA * area_mm2 * layers / MAX_FIELD_TRIANGLES)
    return max(SHELL_STEP_MM, math.ceil(round(needed * 100.0, 6)) / 100.0)


def automatic_lattice(voxels: GridSpec, area_mm2: float, layers: int) -> NodeLattice:
    """Return the voxel centres a build meshes its ``field`` shells from.

    Those about :func:`automatic_step` apart
    (:func:`shellvox.offset.field.layer_field.node_lattice`), farther where the nodes'
    cells (their volume's cube root) are finer than the triangles' bound allows.

    >>> voxels = GridSpec((0.0, 0, 0), (0.0423, 0.0846, 0.027), (9, 9, 9))
    >>> [automatic_lattice(voxels, area, 2).stride_zyx for area in (5000.0, 19127.0)]
    [(4, 1, 2), (4, 1, 3)]
    """
    needed = math.sqrt(TRIANGLES_PER_AREA * area_mm2 * layers / MAX_FIELD_TRIANGLES)
    step = automatic_step(area_mm2, layers)
    while True:
        lattice = node_lattice(voxels, step)
        if lattice_cell_mm(voxels, lattice) >= needed:
            return lattice
        step = round(step + 0.01, 6)
