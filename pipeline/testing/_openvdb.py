"""OpenVDB's own Python module, run as a separate process of Debian's python3.

Debian and Ubuntu package OpenVDB's bindings (``python3-openvdb``, OpenVDB 10, module
``pyopenvdb``) for the system interpreter and its numpy 1.x; the project's environment
runs current numpy, which that module crashes under. These functions therefore ask
``_openvdb_worker.py`` (beside this module, run by ``/usr/bin/python3`` or
``$SHELLVOX_OPENVDB_PYTHON`` in isolated mode) to read, write or level-set, and get plain
data back.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: Debian's interpreter, which sees ``/usr/lib/python3/dist-packages``.
SYSTEM_PYTHON = os.environ.get("SHELLVOX_OPENVDB_PYTHON", "/usr/bin/python3")
#: The script that interpreter runs; it imports ``pyopenvdb`` and numpy, never shellvox.
WORKER = Path(__file__).parent / "_openvdb_worker.py"


class OpenVDBUnavailableError(RuntimeError):
    """Debian's OpenVDB module cannot be run."""


@dataclass(frozen=True)
class GridRead:
    """One grid of a ``.vdb`` file as OpenVDB reads it.

    Attributes
    ----------
    name, grid_class, value_type : str
    active_voxels, leaf_count : int
    background : float or list of float
    metadata : dict
    voxel_size : (3,) float, mm
    active_bbox, leaf_bbox : ((3,) int, (3,) int)
        The active voxels' and the leaves' bounding boxes (index space).
    index_to_world : list of (3,) float
        The world positions of the points asked for, in order.
    values : (X, Y, Z[, 3]) float32 or None
        Its values over the box asked for (OpenVDB's ``ijk`` order: x first).
    active : (X, Y, Z) bool or None
        Its active voxels there (tiles included).
    """

    name: str
    grid_class: str
    value_type: str
    active_voxels: int
    leaf_count: int
    background: Any
    metadata: dict[str, Any]
    voxel_size: tuple[float, float, float]
    active_bbox: tuple[tuple[int, ...], ...] = ()
    leaf_bbox: tuple[tuple[int, ...], ...] = ()
    index_to_world: list[tuple[float, float, float]] = field(default_factory=list)
    values: np.ndarray | None = None
    active: np.ndarray | None = None

    def zyx(self) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(values, active)`` with the axes ``(z, y, x[, c])``, as the voxels."""
        assert self.values is not None and self.active is not None
        axes = (2, 1, 0, 3) if self.values.ndim == 4 else (2, 1, 0)
        return self.values.transpose(axes), self.active.transpose(2, 1, 0)


def _run(request: dict[str, Any]) -> Any:
    """Send one request to the worker in Debian's python3; return its JSON answer."""
    try:
        done = subprocess.run(
            [SYSTEM_PYTHON, "-I", str(WORKER)],
            input=json.dumps(request),
            capture_output=True,
            text=True,
            check=False,
        )
    except OSError as error:
        raise OpenVDBUnavailableError(f"{SYSTEM_PYTHON} cannot run ({error})") from None
    if done.returncode != 0:
        raise OpenVDBUnavailableError(
            f"OpenVDB's module failed in {SYSTEM_PYTHON} ({done.stderr.strip()[-400:]}); "
            "install it with 'sudo apt-get install python3-openvdb' (make setup does)"
        )
    return json.loads(done.stdout)


def read_vdb(
    path: str | Path,
    *,
    dense_xyz: tuple[int, int, int] | None = None,
    points_ijk: list[tuple[int, int, int]] | tuple[()] = (),
) -> dict[str, GridRead]:
    """Read every grid of `path` with OpenVDB; with `dense_xyz`, their values there.

    Parameters
    ----------
    path : str or Path
        A ``.vdb`` file.
    dense_xyz : (3,) int, optional
        The box ``(0, 0, 0)`` .. ``dense_xyz - 1`` (index space) whose values and active
        voxels to read into :attr:`GridRead.values` and :attr:`GridRead.active`.
    points_ijk : list of (3,) int, optional
        Index points whose world positions to read into :attr:`GridRead.index_to_world`.
    """
    with tempfile.TemporaryDirectory() as folder:
        arrays = Path(folder) / "arrays.npz"
        answer = _run(
            {
                "do": "read",
                "path": str(path),
                "dense_xyz": None if dense_xyz is None else list(dense_xyz),
                "points_ijk": [list(p) for p in points_ijk],
                "arrays": str(arrays),
            }
        )
        stored = dict(np.load(arrays)) if dense_xyz is not None else {}
    grids = {}
    for entry in answer["grids"]:
        name = entry["name"]
        grids[name] = GridRead(
            name=name,
            grid_class=entry["class"],
            value_type=entry["value_type"],
            active_voxels=entry["active_voxels"],
            leaf_count=entry["leaf_count"],
            background=entry["background"],
            metadata=entry["metadata"],
            voxel_size=tuple(entry["voxel_size"]),
            active_bbox=tuple(tuple(c) for c in entry["active_bbox"]),
            leaf_bbox=tuple(tuple(c) for c in entry["leaf_bbox"]),
            index_to_world=[tuple(p) for p in entry["index_to_world"]],
            values=stored.get(f"{name}.values"),
            active=stored.get(f"{name}.active"),
        )
    return grids


def describe_grids(grids: dict[str, GridRead]) -> dict[str, Any]:
    """Return ``{name: {class, value_type, active_voxels, voxel_size_mm}}`` of grids.

    `grids` are read by :func:`read_vdb`; the answer has the form of a manifest's ``vdb``
    entry.
    """
    return {
        name: {
            "class": volume.grid_class,
            "value_type": volume.value_type,
            "active_voxels": volume.active_voxels,
            "voxel_size_mm": [float(v) for v in volume.voxel_size],
        }
        for name, volume in grids.items()
    }


def read_grid_metadata(path: str | Path) -> dict[str, dict[str, Any]]:
    """Return each grid's metadata of `path` (statistics included), trees not loaded."""
    answer: dict[str, dict[str, Any]] = _run({"do": "metadata", "path": str(path)})
    return answer


def write_grids(path: str | Path, grids: list[dict[str, Any]]) -> None:
    """Write grids made by OpenVDB from arrays (``copyFromArray``) to `path`.

    Each entry: ``name``, ``array`` ``(X, Y, Z[, 3])``, ``background``, and optionally
    ``level_set`` (flood-fill the sign) and ``class``.
    """
    with tempfile.TemporaryDirectory() as folder:
        arrays = Path(folder) / "arrays.npz"
        named: dict[str, Any] = {
            f"g{i}": np.asarray(g["array"], np.float32) for i, g in enumerate(grids)
        }
        np.savez(arrays, **named)
        specs = [
            {
                "name": g["name"],
                "type": "vec3" if np.ndim(g["array"]) == 4 else "float",
                "background": g["background"],
                "key": f"g{i}",
                "level_set": g.get("level_set", False),
                "class": g.get("class"),
            }
            for i, g in enumerate(grids)
        ]
        _run({"do": "write", "path": str(path), "grids": specs, "arrays": str(arrays)})


def level_set_seconds(
    points: np.ndarray,
    triangles: np.ndarray,
    voxel_mm: float | tuple[float, float, float],
    half_width: float,
) -> dict[str, Any]:
    """Time OpenVDB's mesh-to-level-set (``createLevelSetFromPolygons``) of a mesh.

    Parameters
    ----------
    points : (V, 3) float, mm
    triangles : (F, 3) int
    voxel_mm : float or (3,) float
        The voxel size (one value: cubic voxels).
    half_width : float
        The narrow band's half width, voxels.

    Returns
    -------
    dict
        ``seconds`` (the level set alone: not the load nor the transfer) and
        ``active_voxels``.
    """
    with tempfile.TemporaryDirectory() as folder:
        arrays = Path(folder) / "mesh.npz"
        np.savez(arrays, points=np.asarray(points), triangles=np.asarray(triangles))
        voxel = np.broadcast_to(np.asarray(voxel_mm, dtype=np.float64), (3,)).tolist()
        answer: dict[str, Any] = _run(
            {"do": "level_set", "arrays": str(arrays), "voxel_mm": voxel, "half_width": half_width}
        )
    return answer
