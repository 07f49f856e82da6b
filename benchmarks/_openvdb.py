"""OpenVDB, the benchmarks' peer, run in Debian's own python3 (``python3-openvdb``).

Debian packages OpenVDB's bindings (OpenVDB 10, module ``pyopenvdb``) for the system
interpreter and its numpy 1.x, which the project's environment does not run. Imported,
this module asks a ``/usr/bin/python3`` process (``$SHELLVOX_OPENVDB_PYTHON``) running
this same file for the answer; run as a script it is that process: one JSON request
on stdin, arrays in an ``.npz`` file, one JSON answer on stdout.

- :func:`level_set_seconds`: the seconds of ``createLevelSetFromPolygons`` of a mesh
  (isotropic or anisotropic voxels), and its active voxels;
- :func:`describe_grids`: each grid of a ``.vdb`` file as OpenVDB reads it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

SYSTEM_PYTHON = os.environ.get("SHELLVOX_OPENVDB_PYTHON", "/usr/bin/python3")


def _ask(request: dict[str, Any]) -> Any:
    done = subprocess.run(
        [SYSTEM_PYTHON, "-I", str(Path(__file__).resolve())],
        input=json.dumps(request),
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(
            f"OpenVDB's module failed in {SYSTEM_PYTHON}: {done.stderr.strip()[-400:]}\n"
            "install it with 'sudo apt-get install python3-openvdb' (make setup does)"
        )
    return json.loads(done.stdout)


def level_set_seconds(
    points: np.ndarray,
    triangles: np.ndarray,
    voxel_mm: float | tuple[float, float, float],
    half_width: float,
) -> dict[str, Any]:
    """Time OpenVDB's mesh-to-level-set of a mesh (mm) in its own process.

    Returns ``{"seconds", "active_voxels"}``; the load and the transfer are not timed.
    """
    with tempfile.TemporaryDirectory() as folder:
        arrays = Path(folder) / "mesh.npz"
        np.savez(arrays, points=np.asarray(points), triangles=np.asarray(triangles))
        voxel = [float(voxel_mm)] * 3 if np.ndim(voxel_mm) == 0 else [float(v) for v in voxel_mm]
        answer: dict[str, Any] = _ask(
            {"do": "level_set", "arrays": str(arrays), "voxel_mm": voxel, "half_width": half_width}
        )
    return answer


def describe_grids(path: str | Path) -> dict[str, Any]:
    """Return ``{name: {class, value_type, active_voxels, voxel_size_mm}}`` of a file."""
    answer: dict[str, Any] = _ask({"do": "describe", "path": str(path)})
    return answer


# ----------------------------------------------------------- in Debian's python3 only


def _level_set(request: dict[str, Any]) -> dict[str, Any]:
    import pyopenvdb as vdb

    arrays = np.load(request["arrays"])
    transform = vdb.createLinearTransform()
    transform.scale(tuple(request["voxel_mm"]))
    tick = time.perf_counter()
    grid = vdb.FloatGrid.createLevelSetFromPolygons(
        np.ascontiguousarray(arrays["points"], np.float32),
        triangles=np.ascontiguousarray(arrays["triangles"], np.int32),
        transform=transform,
        halfWidth=float(request["half_width"]),
    )
    seconds = time.perf_counter() - tick
    return {"seconds": seconds, "active_voxels": int(grid.activeVoxelCount())}


def _describe(request: dict[str, Any]) -> dict[str, Any]:
    import pyopenvdb as vdb

    grids, _ = vdb.readAll(request["path"])
    return {
        grid.name: {
            "class": str(grid.gridClass),
            "value_type": grid.valueTypeName,
            "active_voxels": int(grid.activeVoxelCount()),
            "voxel_size_mm": [float(v) for v in grid.transform.voxelSize()],
        }
        for grid in grids
    }


if __name__ == "__main__":
    request = json.load(sys.stdin)
    json.dump({"level_set": _level_set, "describe": _describe}[request["do"]](request), sys.stdout)
