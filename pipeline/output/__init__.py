"""An output folder and what is written into it.

- :mod:`~pipeline.output.outdir` one complete run or none (claiming, replacing, refusing);
- :mod:`~pipeline.output.folder` a build's folder: temporary names, shells, thickness, manifest;
- :mod:`~pipeline.output.streams` the streaming writers fed one slab at a time;
- :mod:`~pipeline.output.manifest` what ``manifest.json`` says; :mod:`~pipeline.output.checks`
  reading it back and checking the files it lists;
- :mod:`~pipeline.output.shells` shell meshes as files; :mod:`~pipeline.output.ply` the
  float64 PLY with per-face values.
"""
