"""An output folder and what is written into it.

- :mod:`~pipeline.output._outdir` one complete run or none (claiming, replacing, refusing);
- :mod:`~pipeline.output._folder` a build's folder: temporary names, shells, thickness, manifest;
- :mod:`~pipeline.output._streams` the streaming writers fed one slab at a time;
- :mod:`~pipeline.output._manifest` what ``manifest.json`` says; :mod:`~pipeline.output._checks`
  reading it back and checking the files it lists;
- :mod:`~pipeline.output._shells` shell meshes as files; :mod:`~pipeline.output._ply` the
  float64 PLY with per-face values.
"""
