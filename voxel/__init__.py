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

Layout
------
- :mod:`shellvox.voxel.grid` ``GridSpec`` (index space vs world space).
- :mod:`shellvox.voxel.slab` ``compute_slab``: the pure per-slab function (layers, colours, SDF
  band); :mod:`shellvox.voxel.tray_slab` a tray's slab, tile by tile; :mod:`shellvox.voxel.sampler`
  reproducible samples per layer; :mod:`shellvox.voxel.agreement` distance layers against shells.
- :mod:`shellvox.voxel.geometry` the kernels: inside tests, exact nearest faces within reach,
  nearest points (the one module :mod:`offset` uses), the per-voxel layer pass.
- :mod:`shellvox.voxel.colour` colour encodings (sRGB, CIELAB), surface colour, separation into
  materials, halftones, the colour report.
- :mod:`shellvox.voxel.io` serialisation only: TIFF, PNG, GrabCAD jobs, OpenVDB, previews and the
  deflate streams; it imports only :mod:`shellvox.voxel.grid` and the sRGB helpers, and
  :mod:`shellvox.voxel.slab` never imports it.
"""
