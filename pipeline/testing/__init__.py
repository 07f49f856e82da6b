"""Checks of what shellvox writes, by tools that are not shellvox's (as numpy.testing).

The tests and the benchmarks import these independent readers from here:

- MeshLab (pymeshlab, the ``testing`` extra), always in a spawned process of its own (it
  crashes now and then): :func:`meshlab_checks`, :func:`meshlab_crossing_faces`,
  :func:`meshlab_read`;
- trimesh's reading of a shell file, :func:`trimesh_checks`, and :func:`ply_header`;
- Debian's OpenVDB (``python3-openvdb``), run by ``/usr/bin/python3`` in a subprocess
  (the project's numpy is too new for it): :func:`read_vdb`, :func:`describe_grids`,
  :func:`read_grid_metadata`, :func:`write_grids`, :func:`level_set_seconds`;
- for the fault tests, the ``shellvox`` command as a process in a session of its own
  (:class:`Command`), its process group listed from ``/proc`` (:func:`group`), and its
  output folder checked against the manifest with hashlib and tifffile
  (:func:`verified_files`, :func:`temporary_files`).

The optional tools (pymeshlab, Debian's OpenVDB) and the heavy ones are imported inside
the functions that use them, so ``import shellvox.testing`` needs nothing beyond
shellvox's own dependencies. Nothing here imports pytest, and nothing in shellvox
imports this package.
"""

from shellvox.testing._build_folder import (
    TEMPORARY_HINTS,
    holds_nothing,
    temporary_files,
    verified_files,
)
from shellvox.testing._meshlab import (
    HAVE_PYMESHLAB,
    MeshLabCrashedError,
    in_own_process,
    meshlab_checks,
    meshlab_crossing_faces,
    meshlab_read,
)
from shellvox.testing._openvdb import (
    GridRead,
    OpenVDBUnavailableError,
    describe_grids,
    level_set_seconds,
    read_grid_metadata,
    read_vdb,
    write_grids,
)
from shellvox.testing._processes import Command, Proc, Run, group, processes
from shellvox.testing._shell_files import count_zero_area_faces, ply_header, trimesh_checks

__all__ = [
    "HAVE_PYMESHLAB",
    "TEMPORARY_HINTS",
    "Command",
    "GridRead",
    "MeshLabCrashedError",
    "OpenVDBUnavailableError",
    "Proc",
    "Run",
    "count_zero_area_faces",
    "describe_grids",
    "group",
    "holds_nothing",
    "in_own_process",
    "level_set_seconds",
    "meshlab_checks",
    "meshlab_crossing_faces",
    "meshlab_read",
    "ply_header",
    "processes",
    "read_grid_metadata",
    "read_vdb",
    "temporary_files",
    "trimesh_checks",
    "verified_files",
    "write_grids",
]
