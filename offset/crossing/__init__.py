"""Crossing tests of triangle meshes: which triangle pairs pass through each other.

- :mod:`~shellvox.offset.crossing.hash_grid` the broad phase (hierarchical hash grid);
- :mod:`~shellvox.offset.crossing.crossing_kernels` the compiled float test;
- :mod:`~shellvox.offset.crossing.exact_crossing` the exact rational confirmation;
- :mod:`~shellvox.offset.crossing.intersections` pairs, counts and coplanar pairs.
"""
