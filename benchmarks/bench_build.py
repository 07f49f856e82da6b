"""``shellvox build`` on the J750 grid: its time against OpenVDB's mesh-to-level-set,
its accuracy, and its memory as the model grows taller.

    python benchmarks/bench_build.py [--part speed|accuracy|memory ...]
        [--cases spot:30,duck:30,airplane:30,spot:100] [--workers 0] [--slab-mb 1024]

Every build is the public API's (:func:`shellvox.build`) with constant layers of
0.5 + 0.5 mm, the TIFFs and the VDB, the offset shells beside the voxels and no
materials (the materials' cost is ``bench_materials_build.py``'s).

``speed`` (each case): the build time next to OpenVDB's ``createLevelSetFromPolygons``
of the same mesh on the same anisotropic grid, run in Debian's python3 in the same
session, with a band of 3 voxels and with a band as deep as the layers, as ratios; also
the peak RSS of the process tree and a large copy's memory bandwidth.
``accuracy`` (the cases under 50 mm): on random voxels of each layer, (a) the layer
against an independent closest-point computation (trimesh, inside from libigl's
winding number), (b) CIEDE2000 of the colour voxels against the colour of the exact
nearest point, (c) the TIFF and VDB (read by OpenVDB) round trips against the manifest.
``memory`` (the first case): peak RSS of the process tree for the model and the model
stretched 2x in z (separate processes): a streamed build should not grow.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import TreeRss, load_average, parser, previous_details, scaled_mesh, write_result

NAME = "bench_build"
WHAT = (
    "Build time of shellvox build on the J750 grid (constant layers 0.5 + 0.5 mm, TIFF "
    "and VDB, shells beside the voxels, no materials) against OpenVDB's "
    "mesh-to-level-set of the same mesh on the same grid, in the same session."
)
PARTS = ("speed", "accuracy", "memory")
CASES = "spot:30,duck:30,airplane:30,spot:100"
THICKNESS = (0.5, 0.5)


def options(args: Any) -> Any:
    import shellvox

    return shellvox.BuildOptions(
        printer="j750",
        formats=("tiff",) if args.no_vdb else ("tiff", "vdb"),
        thickness_mm=THICKNESS,
        layer_rule=args.layers,
        shell_meshes=args.shell_meshes or args.layers == "shells",
        materials=None,
        report_samples=0,
        slab_mb=args.slab_mb,
        workers=args.workers,
    )


def build(mesh: Any, out: Path, args: Any) -> tuple[dict[str, Any], float]:
    """Build `mesh` into `out`; return the manifest and the wall seconds."""
    import shellvox

    started = time.perf_counter()
    result = shellvox.build(mesh, out, options(args), progress=False)
    return result.manifest, time.perf_counter() - started


def accuracy(name: str, size_mm: float, args: Any) -> dict[str, Any]:
    import colour
    import tifffile
    import trimesh
    from scipy import ndimage

    from shellvox.testing import describe_grids, read_vdb
    from shellvox.voxel.geometry import winding_numbers

    mesh = scaled_mesh(name, size_mm)
    with tempfile.TemporaryDirectory(prefix=f"bench-build-{name}-") as folder:
        out = Path(folder) / "build"
        manifest, build_seconds = build(mesh, out, args)
        grid = manifest["grid"]
        voxel = np.asarray(grid["voxel_size_mm"])
        diagonal = float(np.linalg.norm(voxel))
        depth = np.cumsum(THICKNESS)
        rng = np.random.default_rng(0)

        # (c) round trips
        with tifffile.TiffFile(out / "layers.tif") as tiff:
            layers = tiff.asarray()
            meta = tiff.imagej_metadata
            x_res = tiff.pages[0].tags["XResolution"].value
            y_res = tiff.pages[0].tags["YResolution"].value
        tiff_ok = (
            list(layers.shape) == grid["shape_zyx"]
            and abs(meta["spacing"] - voxel[2]) < 1e-9
            and meta["unit"] == "mm"
            and abs(x_res[1] / x_res[0] - voxel[0]) < 1e-6
            and abs(y_res[1] / y_res[0] - voxel[1]) < 1e-6
            and np.bincount(layers.ravel(), minlength=len(depth) + 2).tolist()
            == [layer["voxels"] for layer in manifest["layers"]]
        )
        grids = None if args.no_vdb else describe_grids(read_vdb(out / "volume.vdb"))
        vdb_ok = None if grids is None else grids == manifest["vdb"]

        # (a) layers against independent closest points, on a sample of voxels per layer
        samples = []
        for index in range(len(depth) + 2):
            if index == 0:  # outside voxels within 20 voxels (x) of the model only
                near = ndimage.maximum_filter1d(layers > 0, size=41, axis=2)
                flat = np.flatnonzero(near & (layers == 0))
                del near
            else:
                flat = np.flatnonzero(layers.ravel() == index)
            samples.append(rng.choice(flat, size=min(len(flat), args.samples), replace=False))
        chosen = np.concatenate(samples)
        zyx = np.stack(np.unravel_index(chosen, layers.shape), axis=1)
        centres = np.asarray(grid["origin_mm"]) + zyx[:, ::-1] * voxel
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        closest, distance, face = trimesh.proximity.closest_point(tm, centres)
        inside = winding_numbers(mesh.vertices, mesh.faces, centres) > 0.5
        predicted = np.where(inside, 1 + (distance[:, None] > depth[None, :]).sum(axis=1), 0)
        boundaries = np.concatenate([[0.0], depth])
        clear = np.abs(distance[:, None] - boundaries[None, :]).min(axis=1) > diagonal
        got = layers.ravel()[chosen]
        per_layer = {
            str(index): float(np.mean((got == predicted)[clear & (got == index)]))
            for index in range(len(depth) + 2)
            if np.any(clear & (got == index))
        }
        agreement = float(np.mean((got == predicted)[clear]))

        # (b) colour of colour-layer voxels against the exact nearest point's colour
        del layers
        colour_voxels = got == 1
        rgb = np.zeros((int(colour_voxels.sum()), 3), np.uint8)
        with tifffile.TiffFile(out / "colour.tif") as tiff:
            where = zyx[colour_voxels]
            for z in np.unique(where[:, 0]):  # one page at a time
                page = tiff.pages[int(z)].asarray()
                rows = where[:, 0] == z
                rgb[rows] = page[where[rows, 1], where[rows, 2], :3]
        sizes = {
            str(p.relative_to(out)): p.stat().st_size for p in sorted(out.rglob("*")) if p.is_file()
        }
    bary = trimesh.triangles.points_to_barycentric(
        mesh.vertices[mesh.faces[face[colour_voxels]]], closest[colour_voxels]
    )
    bary = np.clip(bary, 0, 1)
    exact = mesh.colour_at(face[colour_voxels], bary / bary.sum(1)[:, None])[:, :3]

    def lab(values: np.ndarray) -> np.ndarray:
        return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(values / 255.0))

    delta = colour.delta_E(lab(rgb), lab(exact), method="CIE 2000")
    return {
        "model": name,
        "size_mm": size_mm,
        "grid_zyx": grid["shape_zyx"],
        "voxels": int(np.prod(grid["shape_zyx"])),
        "build_seconds": round(build_seconds, 1),
        "manifest_seconds": manifest["seconds"],
        "a_layer_agreement": agreement,
        "a_per_layer": per_layer,
        "a_samples_clear": int(clear.sum()),
        "a_samples": len(chosen),
        "b_ciede2000_median": float(np.median(delta)) if len(delta) else None,
        "b_ciede2000_p99": float(np.percentile(delta, 99)) if len(delta) else None,
        "b_samples": len(delta),
        "c_tiff_round_trip": bool(tiff_ok),
        "c_vdb_matches_manifest": vdb_ok,
        "file_bytes": sizes,
        "voxel_counts": manifest["voxel_counts"],
    }


def child(args: Any) -> dict[str, Any]:
    """One build in this process (``memory``'s child): its seconds and peak RSS."""
    name, size = args.child.split(":")
    mesh = scaled_mesh(name, float(size), stretch_z=args.stretch_z)
    with tempfile.TemporaryDirectory() as out, TreeRss() as tree:
        manifest, seconds = build(mesh, Path(out) / "build", args)
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {
        "stretch_z": args.stretch_z,
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "slab_rows": manifest["slab_rows"],
        "workers": args.workers,
        "seconds": round(seconds, 1),
        "peak_rss_mb": round(max(peak_kb, tree.peak_kb) / 1024, 1),
        "peak_rss_main_process_mb": round(peak_kb / 1024, 1),
    }


def memory(name: str, size_mm: float, args: Any) -> dict[str, Any]:
    runs = []
    for stretch in (1.0, 2.0):
        command = [
            sys.executable, __file__, "--child", f"{name}:{size_mm:g}",
            "--stretch-z", str(stretch), "--slab-mb", str(args.slab_mb),
            "--layers", args.layers, "--workers", str(args.workers),
            "--shell-meshes" if args.shell_meshes else "--no-shell-meshes",
        ] + (["--no-vdb"] if args.no_vdb else [])  # fmt: skip
        done = subprocess.run(command, check=True, capture_output=True, text=True)
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    return {
        "model": name,
        "size_mm": size_mm,
        "slab_mb": args.slab_mb,
        "vdb": not args.no_vdb,
        "runs": runs,
        "rss_ratio_2x_tall": round(runs[1]["peak_rss_mb"] / runs[0]["peak_rss_mb"], 3),
    }


def copy_bandwidth_gb_s(size: int = 2**28) -> float:
    """Memory bandwidth of a large copy (read + write bytes per second), GB/s."""
    source = np.ones(size, dtype=np.uint8)
    target = np.empty_like(source)
    np.copyto(target, source)
    started = time.perf_counter()
    for _ in range(5):
        np.copyto(target, source)
    return 2 * 5 * source.nbytes / (time.perf_counter() - started) / 1e9


def speed(name: str, size_mm: float, args: Any) -> dict[str, Any]:
    from shellvox import load_profile
    from shellvox.run import resolve_workers
    from shellvox.testing import level_set_seconds

    mesh = scaled_mesh(name, size_mm)
    voxel = load_profile("j750").voxel_mm
    deep_half_width = sum(THICKNESS) / min(voxel) + 2
    load_before = load_average()
    vdb = level_set_seconds(mesh.vertices, mesh.faces, voxel, 3.0)
    deep = level_set_seconds(mesh.vertices, mesh.faces, voxel, deep_half_width)
    bandwidth = copy_bandwidth_gb_s(2**22 if args.quick else 2**28)
    with tempfile.TemporaryDirectory() as folder, TreeRss() as tree:
        manifest, build_seconds = build(mesh, Path(folder) / "build", args)
    voxels = int(np.prod(manifest["grid"]["shape_zyx"]))
    counts = manifest["voxel_counts"]
    colour_voxels = sum(v for k, v in counts.items() if k.startswith("colour"))
    workers = resolve_workers(args.workers)
    peak_kb = max(tree.peak_kb, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return {
        "model": name,
        "size_mm": size_mm,
        "layer_rule": args.layers,
        "shell_meshes": args.shell_meshes,
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "voxels": voxels,
        "build_seconds": round(build_seconds, 1),
        "build_breakdown": manifest["seconds"],
        "voxel_counts": counts,
        "file_bytes": {file: record["bytes"] for file, record in manifest["files"].items()},
        "workers": workers,
        "peak_rss_mb": round(peak_kb / 1024, 1),
        "openvdb_mesh_to_level_set_seconds": round(vdb["seconds"], 2),
        "openvdb_active_voxels": vdb["active_voxels"],
        "openvdb_deep_half_width_voxels": round(deep_half_width, 2),
        "openvdb_deep_seconds": round(deep["seconds"], 2),
        "openvdb_deep_active_voxels": deep["active_voxels"],
        "ratio": round(build_seconds / vdb["seconds"], 2),
        "ratio_to_deep_band": round(build_seconds / deep["seconds"], 2),
        "voxels_per_second": round(voxels / build_seconds),
        "colour_voxels_per_second_per_core": round(colour_voxels / build_seconds / workers),
        "copy_bandwidth_gb_s": round(bandwidth, 2),
        "load_average_before": load_before,
        "load_average_after": load_average(),
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per speed case: the build against OpenVDB."""
    return [
        {
            "case": f"{run['model']} {run['size_mm']:g} mm",
            "voxels": run["voxels"],
            "build_s": run["build_seconds"],
            "openvdb_s": run["openvdb_mesh_to_level_set_seconds"],
            "ratio": run["ratio"],
            "openvdb_deep_band_s": run.get("openvdb_deep_seconds"),
            "ratio_to_deep_band": run.get("ratio_to_deep_band"),
            "peak_rss_mb": run.get("peak_rss_mb"),
        }
        for run in details.get("speed", {}).values()
    ]


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--part", action="append", choices=PARTS, help="default: all")
    parsed.add_argument("--cases", default=CASES, help="MESH:SIZE_MM, comma separated")
    parsed.add_argument("--samples", type=int, default=20000, help="voxels sampled per layer")
    parsed.add_argument("--slab-mb", type=float, default=1024.0)
    parsed.add_argument("--no-vdb", action="store_true")
    parsed.add_argument("--workers", type=int, default=0, help="slab processes (0: per core)")
    parsed.add_argument("--layers", choices=("distance", "shells"), default="distance")
    parsed.add_argument("--shell-meshes", action=argparse.BooleanOptionalAction, default=True)
    parsed.add_argument("--child", help=argparse.SUPPRESS)
    parsed.add_argument("--stretch-z", type=float, default=1.0, help=argparse.SUPPRESS)
    args = parsed.parse_args()
    if args.child:
        print(json.dumps(child(args)))
        return
    if args.quick:
        args.cases, args.samples, args.slab_mb = "spot:5", 500, 64.0
        args.shell_meshes = False
    parts = args.part or list(PARTS)
    cases = [(n, float(s)) for n, s in (c.split(":") for c in args.cases.split(","))]
    details = previous_details(NAME, quick=args.quick) if args.part else {}
    details.pop("run", None)
    if "speed" in parts:
        details["speed"] = {}
        for name, size in cases:
            details["speed"][f"{name}_{size:g}mm"] = run = speed(name, size, args)
            print("speed", json.dumps({k: run[k] for k in ("model", "size_mm", "ratio")}))
    if "accuracy" in parts:
        details["accuracy"] = {}
        for name, size in cases:
            if size < 50:  # the whole layers.tif is read
                details["accuracy"][f"{name}_{size:g}mm"] = run = accuracy(name, size, args)
                print("accuracy", name, size, run["a_layer_agreement"], run["c_tiff_round_trip"])
    if "memory" in parts:
        details["memory"] = run = memory(*cases[0], args)
        print("memory", run["rss_ratio_2x_tall"])
    path = write_result(
        NAME,
        {"what": WHAT, "summary": summary(details), "details": details},
        quick=args.quick,
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
