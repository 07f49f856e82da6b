"""Field shells (``shellvox shells --method field``): speed against OpenVDB, validity.

Usage: .venv/bin/python benchmarks/bench_field_shells.py [--part speed|meshes|both]
       [--out benchmarks/results/bench_field_shells.json] [--only NAME,...]

speed: ../shared/meshes/spot with two Loop subdivisions (93,696 faces) at 100 mm, layers
0.5 + 1.0 mm: the whole ``shellvox shells MODEL -o DIR --thickness 0.5,1.0 --no-baselines``
command (a child process: load, field, meshing, simplification, cleaning, files, report)
against OpenVDB's ``createLevelSetFromPolygons`` of the same mesh at 0.05 mm voxels with a
narrow band reaching 1.5 mm (half width ceil(1.5 / 0.05) + 2 voxels), in the same run.

meshes: the shells of every shared mesh (sizes as in bench_offset.py; 3MF files as they are),
each timed as one command.

Both read the files back: trimesh (merged vertices: closed, oriented), MeshLab (duplicate
vertices removed: self-intersecting faces, 2-manifold), the project's crossing test over both
shells together (nested: no crossing, and shell 2's vertices inside shell 1 by winding
numbers), and ``|d - D|`` with libigl's exact distances at 200,000 area-weighted samples and
every vertex (p50, p99 as % of D, max mm). A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from shellvox.loading import load_model
from shellvox.offset.intersections import intersecting_pairs
from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface, winding_numbers

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_offset import SHARED, load_shared  # noqa: E402
from openvdb_module import load_openvdb  # noqa: E402
from shell_file_checks import meshlab_checks, trimesh_checks  # noqa: E402

THICKNESS = "0.5,1.0"
DEPTHS = (0.5, 1.5)
MESHES = {
    "spot_100mm": ("spot/spot_triangulated.obj", 100.0),
    "bunny_50mm": ("bunny/bunny.obj", 50.0),
    "duck_50mm": ("duck/Duck.glb", 50.0),
    "airplane_100mm": ("airplane/colored_airplane.ply", 100.0),
    "box_textured_20mm": ("box-textured/BoxTextured.glb", 20.0),
    "cube_vertexcolor_20mm": ("cube-vertexcolor/cube_with_vertexcolors.obj", 20.0),
    "rhombicuboctahedron_3mf": ("3mf/rhombicuboctahedron_color.3mf", None),
    "pyramid_3mf": ("3mf/pyramid_vertexcolor.3mf", None),
    "box_3mf": ("3mf/box.3mf", None),
}


def run_shells(model: Path, out: Path, extra: list[str]) -> float:
    """Run ``shellvox shells`` as a child process and return its wall time (s)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    command = [sys.executable, "-m", "shellvox.cli", "shells", str(model), "-o", str(out)]
    start = time.perf_counter()
    subprocess.run(
        [*command, "--thickness", THICKNESS, "--no-baselines", "--method", "field", *extra],
        check=True,
        env=env,
    )
    return time.perf_counter() - start


def validity(mesh: trimesh.Trimesh, out: Path) -> dict[str, Any]:
    """Read the shells of `out` back and measure them against `mesh` and each other."""
    surface = SurfaceIndex.build(np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64))
    layers = []
    loaded = []
    for k, depth in enumerate(DEPTHS):
        path = out / f"shell_{k + 1}.ply"
        shell = trimesh.load(path, process=False, force="mesh")
        loaded.append(shell)
        row: dict[str, Any] = {"depth_mm": depth, **trimesh_checks(path)}
        row["meshlab"] = meshlab_checks(path)
        if len(shell.faces):
            points = np.concatenate([shell.sample(200_000, seed=0), shell.vertices])
            error = np.abs(distance_to_surface(surface, points) - depth)
            row["error"] = {
                "p50_pct": float(np.percentile(error, 50) / depth * 100),
                "p99_pct": float(np.percentile(error, 99) / depth * 100),
                "max_mm": float(error.max()),
            }
        layers.append(row)
    outer, inner = loaded
    vertices = np.concatenate([outer.vertices, inner.vertices])
    faces = np.concatenate([outer.faces, inner.faces + len(outer.vertices)])
    crossing = len(intersecting_pairs(vertices, faces)) if len(faces) else 0
    inside = (
        winding_numbers(np.asarray(outer.vertices), np.asarray(outer.faces), inner.vertices)
        if len(inner.faces)
        else np.ones(0)
    )
    report = json.loads((out / "report.json").read_text())
    return {
        "layers": layers,
        "nested": {"crossing_pairs": crossing, "inner_outside_outer": int((inside < 0.5).sum())},
        "method": report["method"],
        "report_seconds": report["seconds"],
    }


def speed(work: Path) -> dict[str, Any]:
    """Time the command on the 93,696-face spot and OpenVDB's level set, same run."""
    mesh = load_shared("spot/spot_triangulated.obj", 100.0, subdivisions=2)
    model = work / "spot94k.ply"
    mesh.export(model)
    load_before = os.getloadavg()
    command_s = run_shells(model, work / "spot94k", [])
    vdb = load_openvdb()
    voxel = 0.05
    transform = vdb.createLinearTransform(voxelSize=voxel)
    start = time.perf_counter()
    grid = vdb.FloatGrid.createLevelSetFromPolygons(
        np.ascontiguousarray(mesh.vertices, dtype=np.float32),
        triangles=np.ascontiguousarray(mesh.faces, dtype=np.int32),
        transform=transform,
        halfWidth=float(np.ceil(1.5 / voxel) + 2),
    )
    vdb_s = time.perf_counter() - start
    result = {
        "mesh": "spot, Loop x2, 93,696 faces, 100 mm, layers 0.5 + 1.0 mm",
        "command_s": command_s,
        "openvdb_s": vdb_s,
        "ratio": command_s / vdb_s,
        "openvdb_voxel_mm": voxel,
        "openvdb_active_voxels": int(grid.activeVoxelCount()),
        "load_average_before": load_before,
        "load_average_after": os.getloadavg(),
        **validity(mesh, work / "spot94k"),
    }
    print(json.dumps({k: result[k] for k in ("command_s", "openvdb_s", "ratio")}), flush=True)
    return result


def meshes(
    work: Path,
    save: Callable[[dict[str, Any]], None] | None = None,
    *,
    only: set[str] | None = None,
    results: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Shells of every shared mesh (or those in `only`), each one command.

    `results` holds earlier results to add to; `save` gets the results so far.
    """
    results = dict(results or {})
    for name, (relative, size) in MESHES.items():
        if only is not None and name not in only:
            continue
        source = SHARED / relative
        if not source.is_file():
            continue
        if size is None:  # a 3MF as it is, read by the project's loader (trimesh needs lxml)
            model, extra = source, []
            loaded = load_model(source)
            mesh = trimesh.Trimesh(loaded.vertices, loaded.faces, process=False)
        else:
            mesh = load_shared(relative, size)
            model, extra = work / f"{name}.ply", []
            mesh.export(model)
        out = work / name
        seconds = run_shells(model, out, extra)
        results[name] = {"seconds": seconds, "n_faces": len(mesh.faces), **validity(mesh, out)}
        print(name, f"{seconds:.1f} s", flush=True)
        if save is not None:
            save(results)
    return results


def main() -> None:
    """Run the parts asked for and merge them into the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("speed", "meshes", "both"), default="both")
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks/results/bench_field_shells.json"
    )
    parser.add_argument("--only", help="comma-separated mesh names of the meshes part")
    args = parser.parse_args()
    results = json.loads(args.out.read_text()) if args.out.is_file() else {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.part in ("speed", "both"):
            results["speed"] = speed(work)
            args.out.write_text(json.dumps(results, indent=1))
        if args.part in ("meshes", "both"):

            def save(so_far: dict[str, Any]) -> None:
                results["meshes"] = so_far
                args.out.write_text(json.dumps(results, indent=1))

            only = None if args.only is None else set(args.only.split(","))
            earlier = results.get("meshes", {}) if only is not None else {}
            save(meshes(work, save, only=only, results=earlier))


if __name__ == "__main__":
    main()
