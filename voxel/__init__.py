"""Voxel grids, layer labelling, surface colour and streaming writers.

Conventions (stated once, used everywhere in this package)
----------------------------------------------------------
- Lengths are millimetres (``_mm`` in names); counts are ``n_``.
- Volumes are indexed ``(z, y, x)``: ``labels : (Z, Y, X) uint8``.
- Points and vectors are ``(x, y, z)``: ``points : (N, 3) float64, mm``.
- Voxel ``(z, y, x)`` has its centre at ``origin_mm + (x * vx, y * vy, z * vz)``, where
  ``origin_mm`` is the centre of voxel ``(0, 0, 0)`` and ``(vx, vy, vz) = voxel_mm``.
- Signed distance is negative inside, as in OpenVDB.
- Layer index: 0 outside, 1..K the shell bands from the outside in, K + 1 the core.

This package never imports :mod:`pipeline` or :mod:`offset`; colour reaches it as a callable
``colour_at(face_ids, barycentric) -> (N, 4) uint8``.

Modules
-------
- :mod:`voxel.grid` ``GridSpec`` (index space vs world space).
- :mod:`voxel.colour.separation`, :mod:`voxel.colour.materials` colour to one material per voxel.
- :mod:`voxel.geometry.winding` exact inside tests (row-crossing winding numbers, symbolic ties).
- :mod:`voxel.geometry.distance_scan` exact nearest faces of the voxels within reach, by scanning
  the Voronoi regions (:mod:`voxel.geometry.voronoi`) of faces, edges and vertices (compiled);
  :mod:`voxel.geometry.closest_point` the compiled point-triangle test it shares with the colour.
- :mod:`voxel.geometry.layer_kernel` the per-voxel pass: layers, SDF band, colour voxels, tallies.
- :mod:`voxel.colour.surface_colour` compiled colour of the nearest points (face, vertex,
  texture), with the numpy path's arithmetic; :mod:`voxel.geometry.nearest` exact nearest points
  by libigl's tree (queries beyond the reach; also generalised winding numbers of points,
  for :mod:`offset` and the shell agreement); :mod:`voxel.colour.colour_at` colour helpers;
  :mod:`voxel.colour.srgb` the sRGB transfer curve and CIELAB (the only place colours change
  encoding; the loaders in :mod:`pipeline` use it too).
- :mod:`voxel.slab` ``compute_slab``: the pure per-slab function (layers, colours, SDF band).
- :mod:`voxel.io.deflate` a compiled run-length deflate (zlib) encoder for slices.
- :mod:`voxel.io.tiff_writer`, :mod:`voxel.io.vdb.writer` (grids cut into leaves by
  :mod:`voxel.io.vdb.encode`, encoded and spooled by :mod:`voxel.io.vdb.leaves`, the file and
  its tree by :mod:`voxel.io.vdb.format`), :mod:`voxel.io.preview`: serialisation only.
- Printer slices, serialisation only: :mod:`voxel.io.gcvf_writer` (GrabCAD Voxel Print
  jobs, described by :mod:`voxel.io.gcvf_job`), :mod:`voxel.io.png_slices` (RGBA slice
  folders), both with PNGs from :mod:`voxel.io.png_encode` and a writer thread from
  :mod:`voxel.io.slab_thread`.
- :mod:`voxel.colour.separation` colour to material proportions (the mixing model's solver in
  :mod:`voxel.colour.mixing`); :mod:`voxel.colour.blue_noise` the
  3D threshold tile; :mod:`voxel.colour.materials` ``materials_for_slab`` (one material per
  voxel); :mod:`voxel.colour.material_kernels` their compiled per-voxel loops (numba).
"""
