"""Benchmarks of ``shellvox build`` against the issue's done-when targets.

Usage (from the repository root; meshes from ../shared/meshes)::

    .venv/bin/python benchmarks/bench_build.py accuracy spot --size-mm 30
    .venv/bin/python benchmarks/bench_build.py memory spot --size-mm 10
    .venv/bin/python benchmarks/bench_build.py speed spot --size-mm 100

``accuracy``: builds at the J750 grid, then checks on random voxel samples (a) the layer
index against an independent closest-point computation (trimesh, with inside/outside from
libigl's generalised winding number), (b) CIEDE2000 of colour-layer voxels against the colour of
the exact nearest point, (c) the TIFF / VDB round trips against manifest.json.
``memory``: peak RSS of the build of the model and of the model stretched 2x in z
(separate processes). ``speed``: build time next to OpenVDB's mesh-to-level-set of the
same mesh on the same (anisotropic) grid, as a ratio.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # vdb_checks, openvdb_module

from openvdb_module import load_openvdb  # noqa: E402

from shellvox.config import BuildConfig, LoadOptions  # noqa: E402
from shellvox.loading import load_model  # noqa: E402
from shellvox.model import ColouredMesh  # noqa: E402
from shellvox.printer import load_profile  # noqa: E402
from shellvox.run import resolve_workers  # noqa: E402
from shellvox.stack import build_stack  # noqa: E402
from shellvox.voxel.geometry import winding_numbers  # noqa: E402

MESHES = ROOT.parent / "shared" / "meshes"
MODELS = {
    "spot": MESHES / "spot" / "spot_triangulated.obj",
    "duck": MESHES / "duck" / "Duck.glb",
    "airplane": MESHES / "airplane" / "colored_airplane.ply",
    "bunny": MESHES / "bunny" / "bunny.obj",
}


def scaled_model(name: str, size_mm: float, stretch_z: float = 1.0) -> ColouredMesh:
    """Load a shared mesh scaled so its largest extent is ``size_mm`` (z stretched)."""
    mesh = load_model(MODELS[name], LoadOptions())
    extent = float(np.ptp(mesh.vertices, axis=0).max())
    vertices = (mesh.vertices - mesh.vertices.min(axis=0)) * (size_mm / extent)
    vertices[:, 2] *= stretch_z
    return dataclasses.replace(mesh, vertices=vertices)


def accuracy(args: argparse.Namespace) -> dict[str, object]:
    import colour
    import tifffile
    import trimesh
    from vdb_checks import describe_grids

    mesh = scaled_model(args.model, args.size_mm)
    config = _config(args)
    out = Path(args.out or tempfile.mkdtemp(prefix=f"shellvox-{args.model}-"))
    started = time.perf_counter()
    manifest = build_stack(mesh, config, out, progress=args.progress)
    build_seconds = time.perf_counter() - started
    grid = manifest["grid"]
    voxel = np.asarray(grid["voxel_size_mm"])
    diagonal = float(np.linalg.norm(voxel))
    depth = np.cumsum(config.thickness_mm)
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
    grids, _ = load_openvdb().readAll(str(out / "volume.vdb"))
    vdb_ok = describe_grids(grids) == manifest["vdb"]

    # (a) layers vs independent closest points on a sample of voxels per layer
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

    # (b) colour of colour-layer voxels vs the exact nearest point's colour
    del layers
    colour_voxels = got == 1
    rgb = np.zeros((int(colour_voxels.sum()), 3), np.uint8)
    with tifffile.TiffFile(out / "colour.tif") as tiff:
        where = zyx[colour_voxels]
        for z in np.unique(where[:, 0]):  # one page at a time
            page = tiff.pages[int(z)].asarray()
            rows = where[:, 0] == z
            rgb[rows] = page[where[rows, 1], where[rows, 2], :3]
    bary = trimesh.triangles.points_to_barycentric(
        mesh.vertices[mesh.faces[face[colour_voxels]]], closest[colour_voxels]
    )
    exact = mesh.colour_at(
        face[colour_voxels], np.clip(bary, 0, 1) / np.clip(bary, 0, 1).sum(1)[:, None]
    )[:, :3]

    def lab(values: np.ndarray) -> np.ndarray:
        return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(values / 255.0))

    delta = colour.delta_E(lab(rgb), lab(exact), method="CIE 2000")
    sizes = {
        str(p.relative_to(out)): p.stat().st_size for p in sorted(out.rglob("*")) if p.is_file()
    }
    return {
        "model": args.model,
        "size_mm": args.size_mm,
        "grid_zyx": grid["shape_zyx"],
        "voxels": int(np.prod(grid["shape_zyx"])),
        "build_seconds": round(build_seconds, 1),
        "manifest_seconds": manifest["seconds"],
        "diagnostics": manifest["diagnostics"],
        "a_layer_agreement": agreement,
        "a_per_layer": per_layer,
        "a_samples_clear": int(clear.sum()),
        "a_samples": len(chosen),
        "b_ciede2000_median": float(np.median(delta)),
        "b_ciede2000_p99": float(np.percentile(delta, 99)),
        "b_samples": len(delta),
        "c_tiff_round_trip": bool(tiff_ok),
        "c_vdb_matches_manifest": bool(vdb_ok),
        "file_bytes": sizes,
        "voxel_counts": manifest["voxel_counts"],
    }


class _TreeRss:
    """Sample the summed RSS of this process and all its descendants (Linux /proc).

    Slab workers are separate processes, so ``ru_maxrss`` of the build process alone
    would understate the build's memory.
    """

    def __init__(self, interval_s: float = 0.05) -> None:
        self.peak_kb = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(interval_s,), daemon=True)

    def __enter__(self) -> _TreeRss:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self, interval_s: float) -> None:
        while not self._stop.wait(interval_s):
            self.peak_kb = max(self.peak_kb, sum(_rss_kb(pid) for pid in _tree(os.getpid())))


def _tree(pid: int) -> list[int]:
    found = [pid]
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        with contextlib.suppress(OSError):
            for child in task.read_text().split():
                found += _tree(int(child))
    return found


def _rss_kb(pid: int) -> int:
    with contextlib.suppress(OSError):
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def _child_build(args: argparse.Namespace) -> dict[str, object]:
    mesh = scaled_model(args.model, args.size_mm, stretch_z=args.stretch_z)
    config = _config(args)
    with tempfile.TemporaryDirectory() as out, _TreeRss() as tree:
        started = time.perf_counter()
        manifest = build_stack(mesh, config, Path(out), progress=False)
        seconds = time.perf_counter() - started
    peak_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {
        "stretch_z": args.stretch_z,
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "slab_rows": manifest["slab_rows"],
        "workers": config.workers,
        "seconds": round(seconds, 1),
        "shell_seconds": round(manifest["seconds"].get("shells", 0.0), 1),
        "peak_rss_mb": round(max(peak_kb, tree.peak_kb) / 1024, 1),
        "peak_rss_main_process_mb": round(peak_kb / 1024, 1),
    }


def memory(args: argparse.Namespace) -> dict[str, object]:
    runs = []
    for stretch in (1.0, 2.0):
        command = [
            sys.executable,
            __file__,
            "child",
            args.model,
            "--size-mm",
            str(args.size_mm),
            "--stretch-z",
            str(stretch),
            "--slab-mb",
            str(args.slab_mb),
            "--layers",
            args.layers,
            "--shell-meshes" if args.shell_meshes else "--no-shell-meshes",
            "--workers",
            str(args.workers),
        ] + (["--no-vdb"] if args.no_vdb else [])
        result = subprocess.run(command, check=True, capture_output=True, text=True)
        runs.append(json.loads(result.stdout.strip().splitlines()[-1]))
    ratio = runs[1]["peak_rss_mb"] / runs[0]["peak_rss_mb"]
    return {"model": args.model, "vdb": not args.no_vdb, "runs": runs, "rss_ratio_2x_tall": ratio}


def _level_set_seconds(mesh: ColouredMesh, voxel: tuple[float, float, float], half_width: float):
    """Time OpenVDB's mesh-to-level-set of `mesh` on the anisotropic grid; (s, active)."""
    vdb = load_openvdb()
    transform = vdb.createLinearTransform()
    transform.scale(voxel)
    started = time.perf_counter()
    level_set = vdb.FloatGrid.createLevelSetFromPolygons(
        mesh.vertices.astype(np.float32),
        triangles=mesh.faces.astype(np.int32),
        transform=transform,
        halfWidth=half_width,
    )
    seconds = time.perf_counter() - started
    active = int(level_set.activeVoxelCount())
    del level_set
    return seconds, active


def _copy_bandwidth_gb_s() -> float:
    """Memory bandwidth of a large copy (read + write bytes per second), GB/s."""
    source = np.ones(2**28, dtype=np.uint8)
    target = np.empty_like(source)
    np.copyto(target, source)
    started = time.perf_counter()
    for _ in range(5):
        np.copyto(target, source)
    return 2 * 5 * source.nbytes / (time.perf_counter() - started) / 1e9


#: Bytes a slab writes per voxel, whatever the method: the inside test (1), its row
#: crossings (2), the nearest-face scan's distance and face (8 + 4), layers (1), colour
#: (4), signed distance and its band (4 + 1), materials (1): the floor of the kernel.
BYTES_WRITTEN_PER_VOXEL = 26


def speed(args: argparse.Namespace) -> dict[str, object]:
    mesh = scaled_model(args.model, args.size_mm)
    voxel = load_profile("j750").voxel_mm
    config = _config(args)
    deepest = float(np.sum(config.thickness_mm))
    deep_half_width = deepest / min(voxel) + 2
    vdb_seconds, vdb_active = _level_set_seconds(mesh, voxel, 3.0)
    deep_seconds, deep_active = _level_set_seconds(mesh, voxel, deep_half_width)
    bandwidth = _copy_bandwidth_gb_s()
    with tempfile.TemporaryDirectory() as out, _TreeRss() as tree:
        started = time.perf_counter()
        manifest = build_stack(mesh, config, Path(out), progress=args.progress)
        build_seconds = time.perf_counter() - started
        sizes = {
            str(p.relative_to(out)): p.stat().st_size for p in Path(out).rglob("*") if p.is_file()
        }
    voxels = int(np.prod(manifest["grid"]["shape_zyx"]))
    counts = manifest["voxel_counts"]
    colour_voxels = sum(v for k, v in counts.items() if k.startswith("colour"))
    workers = resolve_workers(config.workers)
    floor_seconds = voxels * BYTES_WRITTEN_PER_VOXEL / (bandwidth * 1e9 / 2)
    return {
        "model": args.model,
        "size_mm": args.size_mm,
        "layer_rule": config.layer_rule,
        "shell_meshes": config.shell_meshes,
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "voxels": voxels,
        "build_seconds": round(build_seconds, 1),
        "build_breakdown": manifest["seconds"],
        "nearest_queries": manifest["diagnostics"]["nearest_queries"],
        "distance_tests": manifest["diagnostics"].get("distance_tests"),
        "voxel_counts": counts,
        "file_bytes": sizes,
        "workers": workers,
        "peak_rss_mb": round(
            max(tree.peak_kb, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) / 1024, 1
        ),
        "openvdb_mesh_to_level_set_seconds": round(vdb_seconds, 2),
        "openvdb_active_voxels": vdb_active,
        "openvdb_deep_half_width_voxels": round(deep_half_width, 2),
        "openvdb_deep_seconds": round(deep_seconds, 2),
        "openvdb_deep_active_voxels": deep_active,
        "ratio": round(build_seconds / vdb_seconds, 2),
        "ratio_to_deep_band": round(build_seconds / deep_seconds, 2),
        "voxels_per_second": round(voxels / build_seconds),
        "colour_voxels_per_second_per_core": round(colour_voxels / build_seconds / workers),
        "copy_bandwidth_gb_s": round(bandwidth, 2),
        "bytes_written_per_voxel": BYTES_WRITTEN_PER_VOXEL,
        "memory_floor_seconds_one_core": round(floor_seconds, 2),
        "ratio_to_memory_floor_per_core": round(build_seconds * workers / floor_seconds, 1),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }


def _config(args: argparse.Namespace) -> BuildConfig:
    return BuildConfig(
        voxel_mm=load_profile("j750").voxel_mm,
        printer="j750",
        slab_mb=args.slab_mb,
        formats=("tiff",) if args.no_vdb else ("tiff", "vdb"),
        layer_rule=args.layers,
        shell_meshes=args.shell_meshes or args.layers == "shells",
        workers=args.workers,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task", choices=["accuracy", "memory", "speed", "child"])
    parser.add_argument("model", choices=sorted(MODELS))
    parser.add_argument("--size-mm", type=float, default=30.0)
    parser.add_argument("--stretch-z", type=float, default=1.0)
    parser.add_argument("--samples", type=int, default=20000, help="voxels sampled per layer")
    parser.add_argument("--slab-mb", type=float, default=1024.0)
    parser.add_argument("--no-vdb", action="store_true")
    parser.add_argument("--workers", type=int, default=0, help="slab processes (0: per core)")
    parser.add_argument("--layers", choices=("distance", "shells"), default="distance")
    parser.add_argument("--shell-meshes", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--out", help="keep the build here")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None)
    args = parser.parse_args()
    task = {"accuracy": accuracy, "memory": memory, "speed": speed, "child": _child_build}
    print(json.dumps(task[args.task](args)))


if __name__ == "__main__":
    main()
