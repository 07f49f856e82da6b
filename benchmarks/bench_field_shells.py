"""Field shells (``shellvox shells``, the default method): speed against OpenVDB, validity,
and agreement with the exact (robust) construction.

    python benchmarks/bench_field_shells.py [--part speed|meshes|agreement ...]
        [--only NAME,...]

``speed``: spot with two Loop subdivisions (93,696 faces) at 100 mm, layers 0.5 + 1.0 mm:
the whole ``shellvox shells MODEL -o DIR --thickness 0.5,1.0 --no-baselines`` command (a
child process: load, field, meshing, simplification, cleaning, files, report) against
OpenVDB's ``createLevelSetFromPolygons`` of the same mesh at 0.05 mm voxels with a narrow
band reaching 1.5 mm (half width ceil(1.5 / 0.05) + 2 voxels), in the same session.

``meshes``: the shells of every shared mesh (the 3MF files as they are), each timed as one
command (``--only``: some of them).

Both read the files back: trimesh (merged vertices: closed, oriented; the smallest triangle
angle), MeshLab (duplicate vertices removed: self-intersecting faces, 2-manifold; in a
process of its own), the project's crossing test over both shells together (nested: no
crossing, and shell 2's vertices inside shell 1 by winding numbers), and ``|d - D|`` with
libigl's exact distances at 200,000 area-weighted samples and every vertex (p50, p99 as % of
D, max mm).

``agreement``: the 93,696-face spot by the default method and by ``--method robust``
(minutes), each a child process; per layer, volumes, and distances from 200,000
area-weighted samples and every vertex of each shell to the other, both ways (p50, p99,
max; the Hausdorff distance is the larger maximum).

Running some parts keeps the others' results from the current result file.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from _common import load_average, load_shared, mesh_path, parser, previous_details, write_result

from shellvox import load_model
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.testing import (
    MeshLabCrashedError,
    level_set_seconds,
    meshlab_checks,
    trimesh_checks,
)
from shellvox.voxel.geometry._nearest import SurfaceIndex, distance_to_surface, winding_numbers

NAME = "bench_field_shells"
WHAT = (
    "The whole shellvox shells command (field method, layers 0.5 + 1.0 mm) against "
    "OpenVDB's mesh-to-level-set of the same mesh at 0.05 mm with a band to 1.5 mm, "
    "and the shells' validity and depth error on every shared mesh."
)
PARTS = ("speed", "meshes", "agreement")
THICKNESS = "0.5,1.0"
DEPTHS = (0.5, 1.5)
#: name -> (shared mesh, largest side mm; None: a 3MF as it is)
MESHES = {
    "spot_100mm": ("spot", 100.0),
    "bunny_50mm": ("bunny", 50.0),
    "duck_50mm": ("duck", 50.0),
    "airplane_100mm": ("airplane", 100.0),
    "box_textured_20mm": ("box_textured", 20.0),
    "cube_vertexcolor_20mm": ("cube_vertexcolor", 20.0),
    "rhombicuboctahedron_3mf": ("rhombicuboctahedron_3mf", None),
    "pyramid_3mf": ("pyramid_3mf", None),
    "box_3mf": ("box_3mf", None),
}


def run_shells(model: Path, out: Path, extra: list[str]) -> float:
    """Run ``shellvox shells`` as a child process and return its wall time (s)."""
    command = [sys.executable, "-m", "shellvox.cli", "shells", str(model), "-o", str(out)]
    start = time.perf_counter()
    subprocess.run(
        [*command, "--thickness", THICKNESS, "--no-baselines", *extra],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return time.perf_counter() - start


# ------------------------------------------------------------------ reading back


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
        try:  # MeshLab in a spawned process (pymeshlab crashes now and then)
            row["meshlab"] = meshlab_checks(path)
        except MeshLabCrashedError:
            row["meshlab"] = {"crashed": "MeshLab's process died twice"}
        if len(shell.faces):
            # the smallest angle of a triangle (degrees), as trimesh reads the file
            row["min_angle_deg"] = float(np.degrees(shell.face_angles.min()))
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


# ------------------------------------------------------------------------ parts


def speed(work: Path, quick: bool) -> dict[str, Any]:
    """Time the command on the 93,696-face spot and OpenVDB's level set, same session."""
    size, subdivisions = (20.0, 0) if quick else (100.0, 2)
    mesh = load_shared("spot", size, subdivisions)
    model = work / "spot.ply"
    mesh.export(model)
    load_before = load_average()
    command_s = run_shells(model, work / "spot", [])
    voxel = 0.05
    vdb = level_set_seconds(mesh.vertices, mesh.faces, voxel, float(np.ceil(1.5 / voxel) + 2))
    result = {
        "mesh": f"spot, Loop x{subdivisions}, {len(mesh.faces):,} faces, {size:g} mm, "
        "layers 0.5 + 1.0 mm",
        "n_faces": len(mesh.faces),
        "command_s": command_s,
        "openvdb_s": vdb["seconds"],
        "ratio": command_s / vdb["seconds"],
        "openvdb_voxel_mm": voxel,
        "openvdb_active_voxels": vdb["active_voxels"],
        "load_average_before": load_before,
        "load_average_after": load_average(),
        **validity(mesh, work / "spot"),
    }
    print(json.dumps({k: result[k] for k in ("command_s", "openvdb_s", "ratio")}), flush=True)
    return result


def meshes(work: Path, only: set[str] | None, earlier: dict[str, Any]) -> dict[str, Any]:
    """Shells of every shared mesh (or those in `only`), each one command."""
    results = dict(earlier)
    for name, (shared, size) in MESHES.items():
        if only is not None and name not in only:
            continue
        if size is None:  # a 3MF as it is, read by the project's loader (trimesh needs lxml)
            model = mesh_path(shared)
            loaded = load_model(model)
            mesh = trimesh.Trimesh(loaded.vertices, loaded.faces, process=False)
        else:
            mesh = load_shared(shared, size)
            model = work / f"{name}.ply"
            mesh.export(model)
        out = work / name
        seconds = run_shells(model, out, [])
        results[name] = {"seconds": seconds, "n_faces": len(mesh.faces), **validity(mesh, out)}
        print(name, f"{seconds:.1f} s", flush=True)
    return results


def _distances(source: trimesh.Trimesh, target: trimesh.Trimesh) -> dict[str, float]:
    """Return p50, p99 and max of the distance from `source`'s points to `target` (mm)."""
    points = np.concatenate([source.sample(200_000, seed=0), source.vertices])
    index = SurfaceIndex.build(np.asarray(target.vertices), np.asarray(target.faces, np.int64))
    distance = distance_to_surface(index, np.asarray(points, dtype=np.float64))
    return {
        "p50": float(np.percentile(distance, 50)),
        "p99": float(np.percentile(distance, 99)),
        "max": float(distance.max()),
    }


def agreement(work: Path, quick: bool) -> dict[str, Any]:
    """Run the default and the robust method on spot and compare their shells."""
    mesh = load_shared("cube_vertexcolor", 20.0) if quick else load_shared("spot", 100.0, 2)
    model = work / "agreement.ply"
    mesh.export(model)
    seconds = {
        method: run_shells(model, work / method, ["--method", method])
        for method in ("field", "robust")
    }
    result: dict[str, Any] = {
        "mesh": "cube_vertexcolor at 20 mm" if quick else "spot, Loop x2, 93,696 faces, 100 mm",
        "command_s": seconds,
    }
    for layer in (1, 2):
        field, robust = (
            trimesh.load(work / method / f"shell_{layer}.ply", process=False, force="mesh")
            for method in ("field", "robust")
        )
        there, back = _distances(field, robust), _distances(robust, field)
        result[f"shell_{layer}"] = {
            "faces": [len(field.faces), len(robust.faces)],
            "volume_mm3": [float(field.volume), float(robust.volume)],
            "volume_rel_diff": float(field.volume / robust.volume - 1.0),
            "field_to_robust_mm": there,
            "robust_to_field_mm": back,
            "hausdorff_mm": max(there["max"], back["max"]),
        }
    print(json.dumps(result), flush=True)
    return result


def _row(case: str, run: dict[str, Any]) -> dict[str, Any]:
    layers = run["layers"]
    errors = [layer["error"] for layer in layers if "error" in layer]
    meshlab = [layer["meshlab"].get("self_intersecting_faces") for layer in layers]
    return {
        "case": case,
        "input_faces": run.get("n_faces"),
        "seconds": round(run.get("command_s", run.get("seconds", 0.0)), 1),
        "openvdb_s": round(run["openvdb_s"], 1) if "openvdb_s" in run else None,
        "ratio": round(run["ratio"], 2) if "ratio" in run else None,
        "shell_faces": sum(layer["n_faces"] for layer in layers),
        "p99_error_pct": round(max(e["p99_pct"] for e in errors), 3) if errors else None,
        "max_error_mm": round(max(e["max_mm"] for e in errors), 4) if errors else None,
        "closed_oriented": all(layer["closed"] and layer["oriented"] for layer in layers),
        "self_intersecting_faces": sum(m for m in meshlab if m is not None),
        "crossing_pairs": run["nested"]["crossing_pairs"],
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per case: the speed case against OpenVDB, then every shared mesh."""
    rows = []
    if "speed" in details:
        run = details["speed"]
        faces = run.get("n_faces") or int(
            re.search(r"([\d,]+) faces", run["mesh"])[1].replace(",", "")
        )
        rows.append(_row(f"spot {faces:,} faces (speed)", {**run, "n_faces": faces}))
    for name, run in details.get("meshes", {}).items():
        rows.append(_row(name, run))
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--part", action="append", choices=PARTS, help="default: all")
    parsed.add_argument("--only", help="comma-separated mesh names of the meshes part")
    args = parsed.parse_args()
    parts = args.part or list(PARTS)
    details = previous_details(NAME, quick=args.quick) if args.part or args.only else {}
    details.pop("run", None)
    only = None if args.only is None else set(args.only.split(","))
    if args.quick:
        only = {"cube_vertexcolor_20mm"}
    unknown = (only or set()) - set(MESHES)
    if unknown:
        raise SystemExit(f"unknown meshes {sorted(unknown)}; choose among {sorted(MESHES)}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if "speed" in parts:
            details["speed"] = speed(work, args.quick)
        if "meshes" in parts:
            earlier = details.get("meshes", {}) if only is not None else {}
            details["meshes"] = meshes(work, only, earlier)
        if "agreement" in parts:
            details["robust_agreement_spot94k"] = agreement(work, args.quick)
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
