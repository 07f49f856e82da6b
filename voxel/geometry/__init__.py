"""Geometry kernels on the voxel grid (they import only :mod:`shellvox.voxel.grid`).

- :mod:`~shellvox.voxel.geometry._winding` exact inside tests (row-crossing winding numbers);
- :mod:`~shellvox.voxel.geometry._voronoi` the Voronoi regions of faces, edges and vertices, scanned
  by :mod:`~shellvox.voxel.geometry._distance_scan` into the exact nearest faces within reach;
  :mod:`~shellvox.voxel.geometry._closest_point` the compiled point-triangle test;
- :mod:`~shellvox.voxel.geometry._nearest` exact nearest points and generalised winding numbers of
  points (libigl);
- :mod:`~shellvox.voxel.geometry._fast_winding` fast generalised winding numbers of points for any
  triangle soup (open, overlapping, inside out), compiled (Barill et al.'s tree of expansions);
- :mod:`~shellvox.voxel.geometry._solid` the solid of any soup on a voxel grid (winding
  number at least 1/2, sampled where it could decide) and its visible faces;
- :mod:`~shellvox.voxel.geometry._layer_kernel` the per-voxel pass: layers, SDF band, colour voxels;
- :mod:`~shellvox.voxel.geometry._field_nodes` the voxel centres where a slab keeps the layer
  field for the shell meshes.

:mod:`shellvox.offset` uses :mod:`~shellvox.voxel.geometry._nearest`, and its field method
the scan of the nearest faces and the field's nodes (:mod:`shellvox.offset.field`).
"""

from __future__ import annotations

from shellvox.voxel.geometry._closest_point import barycentric
from shellvox.voxel.geometry._distance_scan import nearest_in_reach, nearest_within
from shellvox.voxel.geometry._fast_winding import WindingTree, fast_winding_numbers
from shellvox.voxel.geometry._field_nodes import FieldNodes, NodeLattice, node_lattice
from shellvox.voxel.geometry._layer_kernel import (
    LayerInputs,
    LayerOutputs,
    assign_layers,
    colour_voxels,
    layer_material_counts,
)
from shellvox.voxel.geometry._nearest import (
    Nearest,
    SurfaceIndex,
    closest_barycentric,
    distance_to_surface,
    nearest_faces,
    nearest_on_surface,
    on_faces,
    winding_numbers,
)
from shellvox.voxel.geometry._solid import (
    SolidSlab,
    SoupSolid,
    Visibility,
    boundary_edges,
    solid_slab,
    soup_solid,
    visible_faces,
)
from shellvox.voxel.geometry._voronoi import voronoi_regions
from shellvox.voxel.geometry._winding import inside_slab, winding_slab

__all__ = [
    "FieldNodes",
    "LayerInputs",
    "LayerOutputs",
    "Nearest",
    "NodeLattice",
    "SolidSlab",
    "SoupSolid",
    "SurfaceIndex",
    "Visibility",
    "WindingTree",
    "assign_layers",
    "barycentric",
    "boundary_edges",
    "closest_barycentric",
    "colour_voxels",
    "distance_to_surface",
    "fast_winding_numbers",
    "inside_slab",
    "layer_material_counts",
    "nearest_faces",
    "nearest_in_reach",
    "nearest_on_surface",
    "nearest_within",
    "node_lattice",
    "on_faces",
    "solid_slab",
    "soup_solid",
    "visible_faces",
    "voronoi_regions",
    "winding_numbers",
    "winding_slab",
]
