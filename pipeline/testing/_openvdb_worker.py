"""Run by Debian's own python3 (OpenVDB 10's ``pyopenvdb``, built for Debian's numpy 1.x).

The project's environment runs current numpy, which Debian's module cannot be loaded
with; :mod:`shellvox.testing._openvdb` starts this script, by its path, in a subprocess
instead. It imports only ``pyopenvdb`` (inside the requests, so that importing this
module elsewhere needs nothing) and numpy, never shellvox, and takes one JSON request on
stdin; arrays come and go in ``.npz`` files named in the request; the answer is one JSON
object on stdout.

Requests (``"do"``):

- ``"read"``: every grid of ``path``: name, class, value type, active voxels, background,
  metadata, voxel size, leaf count, ``index_to_world`` of the given ``points_ijk``, and,
  with ``dense_xyz`` (the box ``(0, 0, 0)`` .. ``dense_xyz - 1`` in index space), the
  grid's values and its active voxels (tiles included) there, saved in ``arrays``.
- ``"metadata"``: the file's per-grid statistics metadata, read without the trees.
- ``"write"``: grids made from arrays (``copyFromArray``) written to ``path``: each
  ``{name, type: float|vec3, background, key, level_set, class}``; ``key`` names the
  ``(X, Y, Z[, 3])`` float32 array in ``arrays``.
- ``"level_set"``: OpenVDB's mesh to level set (``createLevelSetFromPolygons``) of the
  mesh in ``arrays`` (``points`` mm, ``triangles``) at ``voxel_mm`` (three sizes) with
  ``half_width`` voxels: its seconds (the level set alone) and active voxels.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

import numpy as np


def _plain(value: Any) -> Any:
    """Return a metadata value as JSON (vectors as lists)."""
    if isinstance(value, bool | int | float | str):
        return value
    try:
        return [_plain(v) for v in value]
    except TypeError:
        return str(value)


def _read(request: dict[str, Any]) -> dict[str, Any]:
    import pyopenvdb as vdb

    grids, file_meta = vdb.readAll(request["path"])
    answer: list[dict[str, Any]] = []
    arrays: dict[str, Any] = {}
    dense = request.get("dense_xyz")
    for grid in grids:
        vec = grid.valueTypeName == "vec3s"
        entry = {
            "name": grid.name,
            "class": str(grid.gridClass),
            "value_type": grid.valueTypeName,
            "active_voxels": int(grid.activeVoxelCount()),
            "background": _plain(grid.background),
            "metadata": {key: _plain(grid[key]) for key in grid.metadata},
            "voxel_size": [float(v) for v in grid.transform.voxelSize()],
            "leaf_count": int(grid.leafCount()),
            "active_bbox": _plain(grid.evalActiveVoxelBoundingBox()),
            "leaf_bbox": _plain(grid.evalLeafBoundingBox()),
            "index_to_world": [
                [float(v) for v in grid.transform.indexToWorld(tuple(p))]
                for p in request.get("points_ijk", [])
            ],
        }
        if dense is not None:
            shape = tuple(dense) + ((3,) if vec else ())
            values = np.zeros(shape, np.float32)
            grid.copyToArray(values, ijk=(0, 0, 0))
            active = np.zeros(tuple(dense), bool)
            for item in grid.iterOnValues():  # voxels and tiles
                lo, hi = item["min"], item["max"]
                active[lo[0] : hi[0] + 1, lo[1] : hi[1] + 1, lo[2] : hi[2] + 1] = True
            arrays[f"{grid.name}.values"] = values
            arrays[f"{grid.name}.active"] = active
        answer.append(entry)
    if dense is not None:
        np.savez(request["arrays"], **arrays)
    return {"grids": answer, "file_metadata": {k: _plain(v) for k, v in file_meta.items()}}


def _metadata(request: dict[str, Any]) -> dict[str, Any]:
    import pyopenvdb as vdb

    return {
        grid.name: {key: _plain(grid[key]) for key in grid.metadata}
        for grid in vdb.readAllGridMetadata(request["path"])
    }


def _write(request: dict[str, Any]) -> dict[str, Any]:
    import pyopenvdb as vdb

    arrays = np.load(request["arrays"])
    grids = []
    for spec in request["grids"]:
        if spec["type"] == "vec3":
            grid = vdb.Vec3SGrid(tuple(spec["background"]))
        else:
            grid = vdb.FloatGrid(float(spec["background"]))
        grid.copyFromArray(np.ascontiguousarray(arrays[spec["key"]], np.float32))
        if spec.get("level_set"):
            grid.signedFloodFill()
        if spec.get("class"):
            grid.gridClass = spec["class"]
        grid.name = spec["name"]
        grids.append(grid)
    vdb.write(request["path"], grids=grids)
    return {"written": len(grids)}


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


def main() -> None:
    """Answer the one request on stdin."""
    request = json.load(sys.stdin)
    do = {"read": _read, "metadata": _metadata, "write": _write, "level_set": _level_set}
    json.dump(do[request["do"]](request), sys.stdout)


if __name__ == "__main__":
    main()
