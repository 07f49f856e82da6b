"""shellvox: per-face colour-layer shells and layered voxel stacks for full-colour 3D printing.

Load a coloured model, give each face its own layer thickness, offset the faces inward
into nested shells, voxelise at the printer's resolution with a colour and a material per
voxel, and write printer jobs, image stacks, OpenVDB grids, an OME-Zarr store and reports::

    import shellvox

    result = shellvox.build("model.obj", "out")  # as `shellvox build model.obj -o out`
    stack = result.open()  # the voxels, lazily, with their grid
    stack.sample([[0.0, 0.0, 1.0]]).layer  # what lies at a point (mm)

The names of this package are loaded on first use (``import shellvox`` imports none of
the heavy libraries). Its parts, each importing only those below it (a test of the
source repository holds them to it):

- :mod:`shellvox.voxel` voxel grids, the compiled kernels, colour, separation and the
  writers; :mod:`shellvox.offset` the shells of the paper's per-face offset;
- the stages: :mod:`~shellvox.errors`, :mod:`~shellvox.config`, :mod:`~shellvox.faults`
  (exit statuses, signals), :mod:`~shellvox.atomic` (files that appear whole);
  :mod:`shellvox.model` the coloured mesh; :mod:`shellvox.loading` (every format to a
  mesh), :mod:`shellvox.thickness` (per-face layer thickness), :mod:`shellvox.printer`
  (profiles, materials, charts); :mod:`shellvox.output` the output folder, its streams,
  manifest, shells and PLY, and :mod:`shellvox.fdm` FDM slicer projects;
  :mod:`shellvox.run` the slab task and where it runs; :mod:`shellvox.stack` one model's
  build; :mod:`shellvox.tray` several models in one job; :mod:`shellvox.api` each command
  as a function; :mod:`shellvox.cli` the command line;
- readers of a finished build: :mod:`shellvox.reading` (arrays), :mod:`shellvox.report`
  (previews) and :mod:`shellvox.viewer` (the browser viewer).
- on top, for the tests and benchmarks only: :mod:`shellvox.testing`, checks of what
  shellvox writes by tools that are not shellvox's (MeshLab, trimesh, OpenVDB).
"""

import lazy_loader

__version__ = "0.1.0"

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
