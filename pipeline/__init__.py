"""shellvox pipeline: model loading, thickness, printers, outputs, runs, builds, the CLI.

Subpackages by stage, each importing only the layers below it (``tests/test_layout.py``
checks the imports):

0. this package's bottom: :mod:`~pipeline.errors`, :mod:`~pipeline.config`,
   :mod:`~pipeline.faults` (exit statuses, signals), :mod:`~pipeline.atomic` (files that
   appear whole);
1. :mod:`pipeline.model` the coloured mesh;
2. :mod:`pipeline.loading` (every format to a mesh), :mod:`pipeline.thickness` (per-face
   layer thickness), :mod:`pipeline.printer` (profiles, the material plan);
3. :mod:`pipeline.output` the output folder, its streams, manifest, shells and PLY;
4. :mod:`pipeline.run` the slab task, where it runs, checkpoints;
5. :mod:`pipeline.build` one model's build; 6. :mod:`pipeline.tray` several models;
7. :mod:`pipeline.cli` the command line.

:mod:`pipeline.report` (previews, the thickness picture) and :mod:`pipeline.viewer` read an
output folder: they import the bottom and :mod:`pipeline.output` only (the previews also
the viewer's stack reader).
"""

__version__ = "0.1.0"
