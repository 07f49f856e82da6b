"""The child of ``bench_materials_build.py``: one build in this process, as ``shellvox build``.

With ``--instrument`` the build's parts are wrapped to sum their CPU time
(:func:`instrument`). Run through ``bench_materials_build.py child`` (see there).
"""

from __future__ import annotations

import argparse
import collections
import functools
import resource
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench_build import MODELS, ROOT, _TreeRss, scaled_model

from shellvox.cli.buildargs import add_build_arguments, config_from_args
from shellvox.cli.thicknessargs import choose_thickness
from shellvox.cli.values import parse_lengths
from shellvox.config import LoadOptions
from shellvox.loading import load_model
from shellvox.printer import load_profile
from shellvox.stack import build_stack

ALL_MODELS = {**MODELS, "colour_target": ROOT / "data" / "colour_target" / "colour_target.obj"}

#: The build options of each variant (beside model, -o, --workers, --slab-mb).
VARIANTS = {
    "A": ["--no-materials", "--format", "tiff,vdb"],
    "B": ["--format", "tiff,vdb,gcvf"],
    "C": ["--format", "tiff,vdb,gcvf,png"],
    "auto": [],  # the CLI's default formats (tiff, vdb and the printer's job)
}


def instrument() -> dict[str, list[float]]:
    """Wrap the build's parts to sum the CPU time (``time.thread_time``) of each call.

    Only this benchmark process is patched, never the code: every wrapped function is a
    leaf of the build's work (none calls another wrapped one), and a thread's CPU time is
    that thread's alone, so the sums do not double count and are not inflated by other
    jobs on the machine. With ``--workers 1`` every part runs in this process.
    Returns ``{part: [cpu_s, wall_s, calls]}``, filled as the build runs.
    """
    import shellvox.run._task as runner
    import shellvox.stack._stack as build_module
    from shellvox.output import OutputFolder, StackOutputs, Tally
    from shellvox.stack import ColourCheck
    from shellvox.voxel.colour import ModelReport
    from shellvox.voxel.io import GcvfWriter, PngSliceWriter, TiffStackWriter
    from shellvox.voxel.io.vdb import VdbStackWriter
    from shellvox.voxel.sampler import LayerSampler

    totals: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0, 0])
    lock = threading.Lock()

    def wrap(owner: Any, name: str, label: str | Callable[[Any], str]) -> None:
        original = getattr(owner, name)

        @functools.wraps(original)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            cpu, wall = time.thread_time(), time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                key = label if isinstance(label, str) else label(args[0])
                with lock:
                    entry = totals[key]
                    entry[0] += time.thread_time() - cpu
                    entry[1] += time.perf_counter() - wall
                    entry[2] += 1

        setattr(owner, name, wrapper)

    def tiff_name(writer: Any) -> str:
        stem = next(n for n in ("materials", "layers", "colour") if n in writer.path.name)
        return f"tiff thread: {stem}.tif (zlib + write)"

    parts: list[tuple[Any, str, str | Callable[[Any], str]]] = [
        (runner, "compute_slab", "compute_slab (voxels)"),
        (runner, "materials_for_slab", "halftone: materials_for_slab (first call loads numba)"),
        (build_module, "build_material_plan", "material plan build (separation table, tile)"),
        (ColourCheck, "__init__", "colour report: sample_surface + rays"),
        (ColourCheck, "result", "colour report: result + thickness_effect"),
        (ModelReport, "add_slab", "colour report: add_slab"),
        (Tally, "add", "tally (Tally.add, + materials bincount in B)"),
        (LayerSampler, "add", "layer sampler"),
        (TiffStackWriter, "write_slab", "tiff write_slab (queue)"),
        (TiffStackWriter, "_write", tiff_name),
        (VdbStackWriter, "write_slab", "vdb write_slab (leaves; + material grid in B)"),
        (VdbStackWriter, "write", "vdb write (file)"),
        (GcvfWriter, "write_slab", "gcvf write_slab (key counts)"),
        (GcvfWriter, "_encode", "gcvf PNG encode (pool threads)"),
        (GcvfWriter, "_add", "gcvf zip write"),
        (GcvfWriter, "close", "gcvf close (padding, xml)"),
        (StackOutputs, "colour_slices", "png: colour_slices"),
        (PngSliceWriter, "_encode", "png PNG encode (pool threads)"),
        (OutputFolder, "commit", "output commit (sha256 of every file)"),
    ]
    for owner, name, label in parts:
        wrap(owner, name, label)
    return totals


def child(args: argparse.Namespace) -> dict[str, Any]:
    """One build in this process, as ``shellvox build`` runs it; return its numbers."""
    totals = instrument() if args.instrument else None
    cpu_start = time.process_time()
    path = ALL_MODELS[args.model]
    if args.size_mm > 0:
        mesh = scaled_model(args.model, args.size_mm, stretch_z=args.stretch_z)
    else:
        mesh = load_model(path, LoadOptions())
    with tempfile.TemporaryDirectory(prefix="shellvox-bench-", dir=args.tmp) as out:
        argv = [
            str(path), "-o", out, "--printer", "j750", "--workers", str(args.workers),
            "--slab-mb", str(args.slab_mb), "--no-shell-meshes", *VARIANTS[args.variant],
        ]  # fmt: skip
        if args.thickness != "rule":
            argv += ["--thickness", args.thickness]
        parser = argparse.ArgumentParser()
        add_build_arguments(parser)
        cli = parser.parse_args(argv)
        profile = load_profile(cli.printer)
        constant = None if cli.thickness is None else parse_lengths("--thickness", cli.thickness)
        tick = time.perf_counter()
        choice = choose_thickness(cli, mesh, constant)
        thickness_seconds = time.perf_counter() - tick
        config = config_from_args(cli, profile, choice)
        with _TreeRss() as tree:
            tick = time.perf_counter()
            manifest = build_stack(
                choice.mesh,
                config,
                Path(out),
                thickness=choice.thickness_mm,
                faces=choice.faces,
                profile=None if config.material is None else profile,
                progress=False,
            )
            wall = time.perf_counter() - tick
        files = {name: record["bytes"] for name, record in manifest["files"].items()}
    png = [name for name in files if name.startswith("slices/")]
    if png:  # one entry for the folder
        files = {k: v for k, v in files.items() if k not in png}
        files["slices/ (all)"] = sum(manifest["files"][n]["bytes"] for n in png)
    main_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    result: dict[str, Any] = {
        "model": args.model,
        "size_mm": args.size_mm or None,
        "stretch_z": args.stretch_z,
        "variant": args.variant,
        "options": argv[3:],
        "formats": list(config.formats),
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "slab_rows": manifest["slab_rows"],
        "workers": args.workers,
        "seconds_total": round(manifest["seconds"]["total"], 2),
        "seconds": {k: round(v, 2) for k, v in manifest["seconds"].items()},
        "build_stack_wall_s": round(wall, 2),
        "thickness_rule_s": round(thickness_seconds, 2),
        "peak_rss_tree_mb": round(max(main_kb, tree.peak_kb) / 1024, 1),
        "peak_rss_main_mb": round(main_kb / 1024, 1),
        "voxel_counts": manifest["voxel_counts"],
        "file_bytes": files,
    }
    if totals is not None:
        result["process_cpu_s"] = round(time.process_time() - cpu_start, 2)
        result["cpu_s_by_part"] = {
            key: {"cpu_s": round(v[0], 2), "wall_s": round(v[1], 2), "calls": int(v[2])}
            for key, v in sorted(totals.items(), key=lambda kv: -kv[1][0])
        }
        result["cpu_s_parts_sum"] = round(sum(v[0] for v in totals.values()), 2)
    if args.full:
        layers = manifest["layers"]
        result["thickness"] = manifest["thickness"]
        result["layer_thickness_mm"] = {
            entry["name"]: entry["thickness_per_face_mm"]
            for entry in layers
            if "thickness_per_face_mm" in entry
        }
        result["materials"] = {m["name"]: m["voxels"] for m in manifest.get("materials", [])}
        result["material_voxels_per_layer"] = manifest.get("material_voxels_per_layer")
        result["colour_report"] = manifest.get("colour_report")
    return result
