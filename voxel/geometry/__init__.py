"""Geometry kernels on the voxel grid (they import only :mod:`voxel.grid`).

- :mod:`~voxel.geometry._winding` exact inside tests (row-crossing winding numbers);
- :mod:`~voxel.geometry._voronoi` the Voronoi regions of faces, edges and vertices, scanned by
  :mod:`~voxel.geometry._distance_scan` into the exact nearest faces within reach;
  :mod:`~voxel.geometry._closest_point` the compiled point-triangle test;
- :mod:`~voxel.geometry._nearest` exact nearest points and generalised winding numbers of
  points (libigl), the one module of :mod:`voxel` that :mod:`offset` uses;
- :mod:`~voxel.geometry._layer_kernel` the per-voxel pass: layers, SDF band, colour voxels.
"""
