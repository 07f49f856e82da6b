"""Colour and materials: encodings, surface colour, separation and halftones.

- :mod:`~voxel.colour.srgb` the sRGB curve and CIELAB (the only place colours change
  encoding; the loaders in :mod:`pipeline` use it too);
- :mod:`~voxel.colour.colour_at` colour of the nearest surface points;
  :mod:`~voxel.colour.surface_colour` the same, compiled, per voxel;
- :mod:`~voxel.colour.separation` colour to material proportions (the mixing model's solver
  in :mod:`~voxel.colour.mixing`); :mod:`~voxel.colour.blue_noise` the 3D threshold tile;
  :mod:`~voxel.colour.materials` one material per voxel, with the compiled loops of
  :mod:`~voxel.colour.material_kernels`;
- :mod:`~voxel.colour.report` predicted printed colour at surface samples.
"""
