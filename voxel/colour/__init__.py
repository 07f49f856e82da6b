"""Colour and materials: encodings, surface colour, separation and halftones.

- :mod:`~voxel.colour._srgb` the sRGB curve and CIELAB (the only place colours change
  encoding; the loaders in :mod:`pipeline` use it too);
- :mod:`~voxel.colour._colour_at` colour of the nearest surface points;
  :mod:`~voxel.colour._surface_colour` the same, compiled, per voxel;
- :mod:`~voxel.colour._separation` colour to material proportions (the mixing model's solver
  in :mod:`~voxel.colour._mixing`); :mod:`~voxel.colour._blue_noise` the 3D threshold tile;
  :mod:`~voxel.colour._materials` one material per voxel, with the compiled loops of
  :mod:`~voxel.colour._material_kernels`;
- :mod:`~voxel.colour._report` predicted printed colour at surface samples.
"""
