"""Build time and memory with 1 and 2 slab workers: forked pool and Dask LocalCluster.

    python benchmarks/bench_scale.py [MODEL ...] [--size-mm 35] [--copies 4] [--repeat 5]
        [--configs fork-1,fork-2] [more build options]

Each configuration runs ``shellvox build`` in a child process (J750 grid by default)
while this script samples the whole process tree with psutil every 0.25 s: the peak RSS
of the main process and of each worker, the forked workers' USS and PSS (what a forked
worker really holds beyond the pages it shares with the parent), and the CPU seconds of
the main process against its workers (the parent's share: writers, halftone, VDB
assembly). Voxels per second are the grid's voxels over the build time the manifest
reports. The peer is the same build with one worker (the speed-up of the median times);
the checkpoint's cost is measured as the same build with ``--no-checkpoint``
(``--configs fork-1,fork-1-checkpoint``). Without MODEL, a tray of ``--copies`` spots.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import psutil
import trimesh
from _common import load_average, mesh_path, parser, write_result

NAME = "bench_scale"
WHAT = (
    "Build time and memory of a tray of spot copies with two slab workers against one "
    "(forked pool; Dask LocalCluster and checkpoints on request), rounds alternating."
)

CONFIGS = {
    "fork-1": ["--workers", "1", "--no-checkpoint"],
    "fork-2": ["--workers", "2", "--no-checkpoint"],
    "dask-local-1": ["--workers", "1", "--scheduler", "local", "--no-checkpoint"],
    "dask-local-2": ["--workers", "2", "--scheduler", "local", "--no-checkpoint"],
    "fork-2-checkpoint": ["--workers", "2", "--checkpoint"],
    "fork-1-checkpoint": ["--workers", "1", "--checkpoint"],
}


def _scale_for(model: Path, size_mm: float) -> float:
    mesh = trimesh.load(model, force="mesh", process=False)
    return size_mm / float(max(mesh.extents))


def _sample(main: psutil.Process, peaks: dict[int, dict[str, float]], cpu: dict[int, float],
            roles: dict[int, str], smaps: bool) -> None:  # fmt: skip
    """CPU times and RSS of the tree (cheap), and USS and PSS if `smaps` (not cheap)."""
    try:
        tree = [main, *main.children(recursive=True)]
    except psutil.Error:
        return
    for process in tree:
        try:
            with process.oneshot():
                times = process.cpu_times()
                cpu[process.pid] = times.user + times.system
                info = process.memory_full_info() if smaps else process.memory_info()
                role = "main" if process.pid == main.pid else _role(process, main)
        except psutil.Error:
            continue
        roles[process.pid] = role
        peak = peaks.setdefault(process.pid, {"rss": 0.0, "uss": 0.0, "pss": 0.0})
        peak["rss"] = max(peak["rss"], info.rss / 2**20)
        peak["uss"] = max(peak["uss"], getattr(info, "uss", 0.0) / 2**20)
        peak["pss"] = max(peak["pss"], getattr(info, "pss", 0.0) / 2**20)


def _role(process: psutil.Process, main: psutil.Process) -> str:
    line = " ".join(process.cmdline())
    if "resource_tracker" in line or "forkserver" in line:
        return "helper"
    if line == " ".join(main.cmdline()):
        return "forked worker"
    if "spawn" in line or "multiprocessing" in line:
        return "spawned worker"
    return "other"


def run_config(
    name: str, models: list[Path], options: list[str], scale: float, smaps_every: float = 2.0
) -> dict[str, Any]:
    """Run one build, sampling every 0.25 s; USS and PSS every `smaps_every` seconds.

    Reading a process's smaps (USS, PSS) costs about 50 ms of CPU for the build's tree;
    every 0.25 s that took a fifth of a core, which two workers on two cores lose and
    one worker does not (its second core has room): a bias against the speed-up.
    """
    with tempfile.TemporaryDirectory(prefix="bench_scale_") as folder:
        out = Path(folder) / "out"
        argv = [sys.executable, "-m", "shellvox.cli", "build", *map(str, models), "-o", str(out),
                "--scale", f"{scale:.8g}", "--no-progress", *options]  # fmt: skip
        started = time.perf_counter()
        child = psutil.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        peaks: dict[int, dict[str, float]] = {}
        cpu: dict[int, float] = {}
        roles: dict[int, str] = {}
        every = max(1, round(smaps_every / 0.25))
        n = 0
        while child.poll() is None:
            _sample(child, peaks, cpu, roles, smaps=n % every == 0)
            n += 1
            time.sleep(0.25)
        wall = time.perf_counter() - started
        stderr = child.stderr.read().decode() if child.stderr else ""
        if child.returncode != 0:
            raise SystemExit(f"{name}: build failed ({child.returncode}):\n{stderr}")
        manifest = json.loads((out / "manifest.json").read_text())
    voxels = 1
    for n in manifest["grid"]["shape_zyx"]:
        voxels *= n
    workers = [pid for pid, role in roles.items() if role.endswith("worker")]
    main_cpu = cpu.get(child.pid, 0.0)
    worker_cpu = sum(cpu[pid] for pid in workers)
    seconds = manifest["seconds"]
    return {
        "config": name,
        "options": options,
        "grid_zyx": manifest["grid"]["shape_zyx"],
        "voxels": voxels,
        "slab_rows": manifest["slab_rows"],
        "slabs": manifest["run"]["slabs"],
        "wall_s": round(wall, 2),
        "build_s": round(seconds["total"], 2),
        "slabs_s": round(seconds.get("slabs", 0.0), 2),
        "voxels_per_s": round(voxels / seconds["total"]),
        "main_peak_rss_mb": round(peaks.get(child.pid, {}).get("rss", 0.0), 1),
        "worker_peak_rss_mb": [round(peaks[pid]["rss"], 1) for pid in workers],
        "worker_peak_uss_mb": [round(peaks[pid]["uss"], 1) for pid in workers],
        "worker_peak_pss_mb": [round(peaks[pid]["pss"], 1) for pid in workers],
        "main_cpu_s": round(main_cpu, 2),
        "workers_cpu_s": round(worker_cpu, 2),
        "main_cpu_share": round(main_cpu / max(main_cpu + worker_cpu, 1e-9), 3),
    }


def _summary(done: list[dict[str, Any]], copies: int, rounds: int) -> dict[str, Any]:
    """Speed-ups 1 -> 2 workers (per round, and of the median times) and checkpoint costs."""
    summary: dict[str, Any] = {}

    def times(name: str, key: str) -> list[float]:
        return [r[key] for r in sorted(done, key=lambda r: r["round"]) if r["config"] == name]

    for kind in ("fork", "dask-local"):
        for key in ("wall_s", "build_s"):
            one, two = times(f"{kind}-1", key), times(f"{kind}-2", key)
            if one and two:
                label = f"copies {copies}: {kind} speed-up 1->2 ({key[:-2]})"
                summary[label] = round(statistics.median(one) / statistics.median(two), 3)
                if rounds > 1:
                    rounds_ = zip(one, two, strict=True)
                    summary[label + " per round"] = [round(a / b, 3) for a, b in rounds_]
    for n in (1, 2):
        on, off = times(f"fork-{n}-checkpoint", "build_s"), times(f"fork-{n}", "build_s")
        if on and off:
            cost = statistics.median(on) / statistics.median(off) - 1
            summary[f"copies {copies}: checkpoint cost fork-{n}"] = round(cost, 3)
    return summary


def summary(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per configuration and tray: median times, and the speed-up over 1 worker."""
    rows = []
    keys = sorted({(r["copies"], r["config"]) for r in results}, key=lambda k: (k[0], k[1]))
    median: dict[tuple[int, str], float] = {}
    for copies, config in keys:
        mine = [r for r in results if r["copies"] == copies and r["config"] == config]
        median[copies, config] = statistics.median(r["wall_s"] for r in mine)
        uss = [u for r in mine for u in r["worker_peak_uss_mb"]]
        rows.append(
            {
                "config": config,
                "copies": copies,
                "rounds": len(mine),
                "median_wall_s": round(median[copies, config], 2),
                "median_build_s": round(statistics.median(r["build_s"] for r in mine), 2),
                "median_voxels_per_s": round(statistics.median(r["voxels_per_s"] for r in mine)),
                "worker_peak_uss_mb": round(max(uss), 1) if uss else None,
                "main_peak_rss_mb": round(max(r["main_peak_rss_mb"] for r in mine), 1),
            }
        )
    for row in rows:
        kind = row["config"].rsplit("-", 1)[0]
        one = median.get((row["copies"], f"{kind}-1"))
        if row["config"].endswith("-2") and one is not None:
            row["speedup_over_1_worker"] = round(one / row["median_wall_s"], 3)
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("models", nargs="*", type=Path, help="default: spot")
    parsed.add_argument("--size-mm", type=float, default=35.0, help="largest extent of a model")
    parsed.add_argument("--configs", default="fork-1,fork-2", help=f"among {','.join(CONFIGS)}")
    parsed.add_argument(
        "--copies", default="4", help="comma list: trays of that many copies (--layout auto)"
    )
    parsed.add_argument(
        "--repeat", type=int, default=5, help="rounds of every configuration (order alternates)"
    )
    parsed.add_argument(
        "--smaps-every", type=float, default=2.0,
        help="seconds between USS/PSS readings (0.25: each sample, for memory studies)",
    )  # fmt: skip
    args, extra = parsed.parse_known_args()  # the rest: more build options
    if args.quick:
        args.size_mm, args.copies, args.repeat = 5.0, "1", 1
    models = args.models or [mesh_path("spot")]
    scale = _scale_for(models[0], args.size_mm)
    results = []
    summary_old: dict[str, float] = {}
    configs = args.configs.split(",")
    load_start = load_average()
    for copies in (int(c) for c in args.copies.split(",")):
        tray = ["--copies", str(copies)] if copies > 1 else []
        done = []
        for round_ in range(args.repeat):
            # Alternate the order: a machine that speeds up or slows down during the
            # rounds favours neither configuration.
            for name in configs if round_ % 2 == 0 else configs[::-1]:
                options = [*CONFIGS[name], *tray, *extra]
                result = run_config(name, models, options, scale, args.smaps_every)
                result["copies"], result["round"] = copies, round_
                print(json.dumps(result), flush=True)
                done.append(result)
        results += done
        summary_old.update(_summary(done, copies, args.repeat))
    record = {
        "models": [str(m) for m in models],
        "size_mm": args.size_mm,
        "copies": args.copies,
        "repeat": args.repeat,
        "smaps_every_s": args.smaps_every,
        "extra_options": extra,
        "cores": len(os.sched_getaffinity(0)),
        "load_average_at_start": load_start,
        "results": results,
        "speedups": summary_old,
    }
    print(json.dumps(summary_old, indent=2))
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(results), "details": record}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
