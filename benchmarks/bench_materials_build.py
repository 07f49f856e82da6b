"""What materials, halftone and printer slices cost a whole ``shellvox build``.

    nice python benchmarks/bench_materials_build.py [--part overhead|memory|report|compile ...]
        [--rounds 3]

Every build runs in its own child process, through the same steps as ``shellvox build``
(the public API: :func:`shellvox.layer_thickness`, ``BuildOptions.config``,
:func:`shellvox.stack.build_stack`) on spot at 30 mm. The build time is the manifest's
``seconds.total`` (all of ``build_stack``; the thickness rule, computed before it, is
timed apart).

``overhead``: spot at 30 mm, J750 grid, 2 workers, ``--thickness 0.5,0.5``, no shell
meshes: A = no materials, ``tiff,vdb`` (the peer); B = materials with ``tiff,vdb,gcvf``;
C = B plus ``png``. Rounds alternate the order (A B C, C B A, ...); each run records the
load average and the CPU the rest of the machine used meanwhile (``/proc/stat`` minus
the child's own rusage). The claim: B adds at most 30 % to A's time (median ratio).
``memory``: peak RSS of B summed over the process tree, the model and the model twice
as tall (``--slab-mb 256``): it should not grow with the height.
``report``: the colour report (default thickness rule, the default formats) for spot,
the duck and the airplane at 30 mm and the default model, and the default model with
``--thickness 0.5,0.5``.
``compile``: the material kernels' first call with an empty numba cache and a warm one.

Running some parts keeps the others' results from the current result file.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import (
    TreeRss,
    load_average,
    mesh_path,
    parser,
    previous_details,
    scaled_mesh,
    write_result,
)

NAME = "bench_materials_build"
WHAT = (
    "Build time of shellvox build on the J750 grid with materials, halftone and the "
    "printer job (B) and with PNG slices too (C), against the same build without "
    "materials (A), alternating in one session."
)
PARTS = ("overhead", "memory", "report", "compile")

#: The formats and materials of each variant (None: the defaults of ``shellvox build``).
VARIANTS: dict[str, tuple[tuple[str, ...] | None, bool]] = {
    "A": (("tiff", "vdb"), False),
    "B": (("tiff", "vdb", "gcvf"), True),
    "C": (("tiff", "vdb", "gcvf", "png"), True),
    "auto": (None, True),
}


# ---------------------------------------------------------------------- the child build


def child(args: argparse.Namespace) -> dict[str, Any]:
    """One build in this process, as ``shellvox build`` runs it; return its numbers."""
    import shellvox
    from shellvox.stack import build_stack

    if args.size_mm > 0:
        mesh = scaled_mesh(args.model, args.size_mm, stretch_z=args.stretch_z)
    else:
        mesh = shellvox.load_model(mesh_path(args.model))
    formats, materials = VARIANTS[args.variant]
    constant = None if args.thickness == "rule" else tuple(map(float, args.thickness.split(",")))
    options = shellvox.BuildOptions(
        printer="j750",
        formats=formats,
        thickness_mm=constant,
        materials=shellvox.MaterialSettings() if materials else None,
        report_samples=args.report_samples,
        slab_mb=args.slab_mb,
        workers=args.workers,
    )
    profile = shellvox.load_profile("j750")
    with tempfile.TemporaryDirectory(prefix="shellvox-bench-", dir=args.tmp) as out:
        tick = time.perf_counter()
        choice = shellvox.layer_thickness(
            mesh, thickness_mm=constant, printer=profile, materials=options.materials
        )
        thickness_seconds = time.perf_counter() - tick
        config = options.config(profile, choice)
        with TreeRss() as tree:
            tick = time.perf_counter()
            manifest = build_stack(
                choice.mesh,
                config,
                Path(out) / "build",
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
        "formats": list(config.formats),
        "materials": config.material is not None,
        "thickness": args.thickness,
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
    if args.full:
        result["layer_thickness_mm"] = {
            entry["name"]: entry["thickness_per_face_mm"]
            for entry in manifest["layers"]
            if "thickness_per_face_mm" in entry
        }
        result["material_voxels"] = {m["name"]: m["voxels"] for m in manifest.get("materials", [])}
        result["colour_report"] = manifest.get("colour_report")
    return result


# ------------------------------------------------------------------------ orchestration


def _child_command(args: argparse.Namespace, variant: str, **options: Any) -> list[str]:
    values = {
        "model": args.model,
        "size_mm": args.size_mm,
        "stretch_z": 1.0,
        "workers": 2,
        "slab_mb": 512.0,
        "thickness": "0.5,0.5",
        "full": False,
        **options,
    }
    command = [
        sys.executable, str(Path(__file__).resolve()), "--child", "--variant", variant,
        "--model", values["model"], "--size-mm", str(values["size_mm"]),
        "--stretch-z", str(values["stretch_z"]), "--workers", str(values["workers"]),
        "--slab-mb", str(values["slab_mb"]), "--thickness", values["thickness"],
    ]  # fmt: skip
    if args.tmp:
        command += ["--tmp", args.tmp]
    if args.quick:
        command += ["--report-samples", "500"]
    return command + (["--full"] if values["full"] else [])


def _proc_stat_busy() -> float:
    """Return the busy jiffies of all CPUs since boot."""
    fields = [float(v) for v in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    return sum(fields) - fields[3] - fields[4]  # not idle, not iowait


def run_child(command: list[str]) -> dict[str, Any]:
    """Run one child build; add the machine load and the CPU others used meanwhile."""
    before_load = load_average()
    busy0 = _proc_stat_busy()
    own0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    tick = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - tick
    if done.returncode != 0:
        raise RuntimeError(f"{command} failed:\n{done.stderr[-3000:]}")
    busy1 = _proc_stat_busy()
    own1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    own_cpu = (own1.ru_utime - own0.ru_utime) + (own1.ru_stime - own0.ru_stime)
    machine_cpu = (busy1 - busy0) / os.sysconf("SC_CLK_TCK")
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    result: dict[str, Any] = json.loads(lines[-1])
    result["process_wall_s"] = round(wall, 1)
    result["cpu_s_this_run"] = round(own_cpu, 1)
    result["cpu_cores_used_by_others"] = round(max(0.0, machine_cpu - own_cpu) / wall, 2)
    result["loadavg_before"] = before_load
    result["loadavg_after"] = load_average()
    return result


def _brief(run: dict[str, Any]) -> str:
    return (
        f"{run['variant']} {run.get('model')} {run['seconds_total']:.1f} s "
        f"(cpu {run['cpu_s_this_run']} s, others {run['cpu_cores_used_by_others']} cores, "
        f"load {run['loadavg_before'][0]}) rss {run['peak_rss_tree_mb']} MB"
    )


def overhead(args: argparse.Namespace) -> dict[str, Any]:
    variants = ["A", "B", "C"] if args.png else ["A", "B"]
    runs: list[dict[str, Any]] = []
    warm = None
    if not args.quick:
        warm = run_child(_child_command(args, "B"))  # numba cache, page cache; not counted
        print("warm-up", _brief(warm), flush=True)
    for round_index in range(args.rounds):
        order = variants if round_index % 2 == 0 else variants[::-1]
        for variant in order:
            run = run_child(_child_command(args, variant))
            run["round"] = round_index
            runs.append(run)
            print(round_index, _brief(run), flush=True)
    return {
        "setup": f"{args.model} {args.size_mm:g} mm, J750 grid, 2 workers, --thickness 0.5,0.5, "
        "no shell meshes; A = --no-materials --format tiff,vdb; B = --format tiff,vdb,gcvf; "
        "C = B + png",
        "cpus": os.cpu_count(),
        "warmup_run": warm,
        "runs": runs,
        "summary": overhead_summary(runs, variants),
    }


def overhead_summary(runs: list[dict[str, Any]], variants: list[str]) -> dict[str, Any]:
    """Ratios to A per round (paired runs) of build seconds and of CPU seconds."""
    wall: dict[int, dict[str, float]] = collections.defaultdict(dict)
    cpu_s: dict[int, dict[str, float]] = collections.defaultdict(dict)
    for run in runs:
        wall[run["round"]][run["variant"]] = run["seconds_total"]
        cpu_s[run["round"]][run["variant"]] = run["cpu_s_this_run"]
    summary: dict[str, Any] = {}
    for variant in variants[1:]:
        ratios = [r[variant] / r["A"] for r in wall.values()]
        cpu_ratios = [r[variant] / r["A"] for r in cpu_s.values()]
        summary[f"{variant}_over_A"] = {
            "ratios_per_round": [round(v, 3) for v in ratios],
            "median_ratio": round(statistics.median(ratios), 3),
            "ratio_of_medians": round(
                statistics.median(r[variant] for r in wall.values())
                / statistics.median(r["A"] for r in wall.values()),
                3,
            ),
            "min_over_min": round(
                min(r[variant] for r in wall.values()) / min(r["A"] for r in wall.values()), 3
            ),
            "cpu_ratios_per_round": [round(v, 3) for v in cpu_ratios],
            "cpu_median_ratio": round(statistics.median(cpu_ratios), 3),
        }
    for variant in variants:
        times = [r[variant] for r in wall.values()]
        summary[f"{variant}_seconds"] = {"all": times, "median": statistics.median(times)}
        cpus = [r[variant] for r in cpu_s.values()]
        summary[f"{variant}_cpu_seconds"] = {"all": cpus, "median": statistics.median(cpus)}
    return summary


def memory(args: argparse.Namespace) -> dict[str, Any]:
    runs = []
    for stretch in (1.0, 2.0):
        run = run_child(_child_command(args, "B", stretch_z=stretch, slab_mb=256.0))
        runs.append(run)
        print(stretch, _brief(run), flush=True)
    return {
        "setup": f"B (materials, tiff+vdb+gcvf), {args.model} {args.size_mm:g} mm and stretched "
        "2x in z, 2 workers, --slab-mb 256, --thickness 0.5,0.5, no shell meshes; peak RSS "
        "summed over the process tree, sampled every 50 ms",
        "runs": runs,
        "rss_ratio_2x_tall": round(runs[1]["peak_rss_tree_mb"] / runs[0]["peak_rss_tree_mb"], 3),
    }


def report(args: argparse.Namespace) -> dict[str, Any]:
    cases = [
        ("spot", 30.0, "rule"),
        ("duck", 30.0, "rule"),
        ("airplane", 30.0, "rule"),
        ("default", 0.0, "rule"),
        ("default", 0.0, "0.5,0.5"),
    ]
    if args.quick:
        cases = [(args.model, args.size_mm, "rule")]
    results: dict[str, Any] = {
        "setup": "J750 grid, the default formats of shellvox build, 2 workers, no shell "
        "meshes, default material settings, 20000 report samples"
    }
    for model, size, thickness in cases:
        command = _child_command(
            args, "auto", model=model, size_mm=size, thickness=thickness, full=True
        )
        run = run_child(command)
        key = f"{model}{'_' + str(int(size)) + 'mm' if size else ''}_" + (
            "rule" if thickness == "rule" else "constant_" + thickness.replace(",", "_")
        )
        results[key] = run
        stats = (run.get("colour_report") or {}).get("ciede2000", {})
        print(key, _brief(run), json.dumps(stats), flush=True)
    return results


def compile_cost(args: argparse.Namespace) -> dict[str, Any]:
    """First call of the material kernels with an empty numba cache and with a warm one."""
    code = (
        "import time, numpy as np\n"
        "t = time.perf_counter()\n"
        "from shellvox import MaterialSettings, load_profile\n"
        "from shellvox.printer import build_material_plan\n"
        "from shellvox.voxel.colour import materials_for_slab\n"
        "t_import = time.perf_counter() - t\n"
        "t = time.perf_counter()\n"
        "plan = build_material_plan(load_profile('j750'), MaterialSettings(),"
        " colour_layers=(1,), n_bands=2)\n"
        "t_plan = time.perf_counter() - t\n"
        "t = time.perf_counter()\n"
        "materials_for_slab(np.ones((2, 4, 4), np.uint8), np.zeros((2, 4, 4, 4), np.uint8),"
        " 0, plan)\n"
        "print(t_import, t_plan, time.perf_counter() - t)\n"
    )
    results: dict[str, Any] = {}
    cache = tempfile.mkdtemp(prefix="numba-cache-")
    env = {**os.environ, "NUMBA_CACHE_DIR": cache}
    for label in ("cold_cache", "warm_cache"):
        out = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        ).stdout.split()
        results[label] = {
            "import_s": round(float(out[0]), 2),
            "plan_build_s": round(float(out[1]), 2),
            "first_kernel_call_s": round(float(out[2]), 2),
        }
    shutil.rmtree(cache)
    results["loadavg"] = load_average()
    results["note"] = (
        "each forked slab worker makes its own first call (the plan is built in the parent "
        "before the fork, the kernel is first called in the workers)"
    )
    return results


VARIANT_LABELS = {
    "A": "A: no materials (tiff, vdb)",
    "B": "B: materials (tiff, vdb, gcvf)",
    "C": "C: B + png slices",
}


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per variant of the overhead part: median seconds and the ratio to A."""
    found = details.get("overhead", {}).get("summary", {})
    rows = []
    for variant, label in VARIANT_LABELS.items():
        if f"{variant}_seconds" not in found:
            continue
        ratio = found.get(f"{variant}_over_A", {})
        rows.append(
            {
                "variant": label,
                "median_build_s": found[f"{variant}_seconds"]["median"],
                "median_cpu_s": found[f"{variant}_cpu_seconds"]["median"],
                "median_ratio_to_A": ratio.get("median_ratio", 1.0),
                "cpu_median_ratio_to_A": ratio.get("cpu_median_ratio", 1.0),
            }
        )
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--part", action="append", choices=PARTS, help="default: all")
    parsed.add_argument("--rounds", type=int, default=3)
    parsed.add_argument("--png", action=argparse.BooleanOptionalAction, default=True)
    parsed.add_argument("--tmp", help="folder for the builds' temporary outputs")
    parsed.add_argument("--model", default="spot", help="a shared mesh name, or 'default'")
    parsed.add_argument("--size-mm", type=float, default=30.0, help="0: the file's own size")
    # the child's options
    parsed.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parsed.add_argument("--variant", choices=sorted(VARIANTS), default="B", help=argparse.SUPPRESS)
    parsed.add_argument("--stretch-z", type=float, default=1.0, help=argparse.SUPPRESS)
    parsed.add_argument("--workers", type=int, default=2, help=argparse.SUPPRESS)
    parsed.add_argument("--slab-mb", type=float, default=512.0, help=argparse.SUPPRESS)
    parsed.add_argument("--thickness", default="0.5,0.5", help=argparse.SUPPRESS)
    parsed.add_argument("--full", action="store_true", help=argparse.SUPPRESS)
    parsed.add_argument("--report-samples", type=int, default=20_000, help=argparse.SUPPRESS)
    args = parsed.parse_args()
    if args.child:
        print(json.dumps(child(args)))
        return
    if args.quick:
        args.size_mm, args.rounds, args.png = 5.0, 1, False
    parts = args.part or list(PARTS)
    details = previous_details(NAME, quick=args.quick) if args.part else {}
    details.pop("run", None)
    tasks = {"overhead": overhead, "memory": memory, "report": report, "compile": compile_cost}
    for part in parts:
        started = time.perf_counter()
        details[part] = tasks[part](args)
        details[part]["bench_seconds"] = round(time.perf_counter() - started, 1)
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
