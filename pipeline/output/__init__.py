"""An output folder and what is written into it.

- :mod:`~shellvox.output._outdir` one complete run or none (claiming, replacing, refusing);
- :mod:`~shellvox.output._folder` a build's folder: temporary names, shells, thickness, manifest;
- :mod:`~shellvox.output._streams` the streaming writers fed one slab at a time;
- :mod:`~shellvox.output._manifest` what ``manifest.json`` says; :mod:`~shellvox.output._checks`
  reading it back and checking the files it lists;
- :mod:`~shellvox.output._shells` shell meshes as files; :mod:`~shellvox.output._ply` the
  float64 PLY with per-face values; :mod:`~shellvox.output._proof` the soft proof's
  point cloud (``proof.ply``).
"""

from __future__ import annotations

from shellvox.output._checks import (
    check_files,
    file_summary,
    manifest_line,
    read_manifest,
    verify_files,
)
from shellvox.output._folder import BuildFolder
from shellvox.output._manifest import Tally, stack_manifest
from shellvox.output._outdir import LOCK_NAME, SHELL_OUTPUTS, OutputFolder, remove_leftovers, sha256
from shellvox.output._ply import read_face_ply, write_ply, write_thickness_ply
from shellvox.output._proof import PROOF_FILE, read_proof_ply, write_proof_ply
from shellvox.output._shells import read_ply, save_shells, write_shell
from shellvox.output._streams import StackOutputs, gcvf_slices, gcvf_writer, zarr_shards

__all__ = [
    "LOCK_NAME",
    "PROOF_FILE",
    "SHELL_OUTPUTS",
    "BuildFolder",
    "OutputFolder",
    "StackOutputs",
    "Tally",
    "check_files",
    "file_summary",
    "gcvf_slices",
    "gcvf_writer",
    "manifest_line",
    "read_face_ply",
    "read_manifest",
    "read_ply",
    "read_proof_ply",
    "remove_leftovers",
    "save_shells",
    "sha256",
    "stack_manifest",
    "verify_files",
    "write_ply",
    "write_proof_ply",
    "write_shell",
    "write_thickness_ply",
    "zarr_shards",
]
