"""Geometry kernels on the voxel grid (they import only :mod:`voxel.grid`).

- :mod:`~voxel.geometry.winding` exact inside tests (row-crossing winding numbers);
- :mod:`~voxel.geometry.voronoi` the Voronoi regions of faces, edges and vertices, scanned by
  :mod:`~voxel.geometry.distance_scan` into the exact nearest faces within reach;
  :mod:`~voxel.geometry.closest_point` the compiled point-triangle test;
- :mod:`~voxel.geometry.nearest` exact nearest points and generalised winding numbers of
  points (libigl), the one module of :mod:`voxel` that :mod:`offset` uses;
- :mod:`~voxel.geometry.layer_kernel` the per-voxel pass: layers, SDF band, colour voxels.
"""
