"""What materials, halftone and printer slices cost a whole ``shellvox build`` (issue 10).

Usage (from the repository root; meshes from ../shared/meshes)::

    nice .venv/bin/python benchmarks/bench_materials_build.py overhead --rounds 3
    nice .venv/bin/python benchmarks/bench_materials_build.py profile
    nice .venv/bin/python benchmarks/bench_materials_build.py memory
    nice .venv/bin/python benchmarks/bench_materials_build.py report
    nice .venv/bin/python benchmarks/bench_materials_build.py compile

Every build runs in its own child process (``child``), through the same steps as
``shellvox build`` (its argument parser, :func:`choose_thickness`,
:func:`config_from_args`, :func:`build_stack`) on a mesh loaded and scaled as
``bench_build.py`` does. The build time is the manifest's ``seconds.total`` (all of
``build_stack``; the thickness rule, computed before it, is timed apart).

``overhead``: spot at 30 mm, J750 grid, 2 workers, ``--thickness 0.5,0.5``,
``--no-shell-meshes``: A = ``--no-materials --format tiff,vdb``, B = materials with
``--format tiff,vdb,gcvf``, C = B plus ``png``. Rounds alternate the order (A B C,
C B A, ...) on a machine shared with other jobs; each run records the load average and
the CPU the rest of the machine used meanwhile (``/proc/stat`` minus the child's own
rusage). The done-when: B adds at most 30 % to A's time (median ratio over rounds).
``profile``: A and B once each under ``py-spy record --subprocesses`` (sampling the
main process, its writer threads and the slab workers); seconds sampled per part of
the build (the innermost recognised frame of each sample). Samples count running *or
runnable* threads, so on a busy machine they exceed CPU time: see ``cpu``.
``memory``: peak RSS of B summed over the process tree, the model and the model twice
as tall (``--slab-mb 256`` as ``bench_build.py memory``).
``report``: the colour report (default thickness rule) for spot, duck, airplane at 30 mm
and the default model, and the default model with ``--thickness 0.5,0.5``.
``compile``: the numba kernels' first call with an empty cache and with a warm one.
``cpu``: A and B with one worker (every part in one process), the CPU time
(``time.thread_time``) of each part of the build, by wrapping its functions in this
process (compute_slab's own is an undercount: libigl's threads do part of it).
``reparse``: parse the kept py-spy samples (``results/*_pyspy_*.txt.gz``) again.
Results go to ``benchmarks/results/bench_materials_build.json`` (one key per part).
A benchmark, not a test.
"""

from __future__ import annotations

import argparse
import collections
import fcntl
import gzip
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
from typing import Any, cast

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from materials_build_child import ALL_MODELS, VARIANTS, child  # noqa: E402
from pyspy_parts import parse_raw  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "bench_materials_build.json"
PY_SPY = Path(sys.executable).parent / "py-spy"


# --------------------------------------------------------------------------- orchestration


def _child_command(args: argparse.Namespace, variant: str, **options: Any) -> list[str]:
    values = {
        "model": args.model,
        "size_mm": args.size_mm,
        "stretch_z": 1.0,
        "workers": 2,
        "slab_mb": 512.0,
        "thickness": "0.5,0.5",
        "full": False,
        "instrument": False,
        **options,
    }
    command = [
        sys.executable, str(Path(__file__).resolve()), "child", "--variant", variant,
        "--model", values["model"], "--size-mm", str(values["size_mm"]),
        "--stretch-z", str(values["stretch_z"]), "--workers", str(values["workers"]),
        "--slab-mb", str(values["slab_mb"]), "--thickness", values["thickness"],
    ]  # fmt: skip
    if args.tmp:
        command += ["--tmp", args.tmp]
    command += ["--full"] if values["full"] else []
    return command + (["--instrument"] if values["instrument"] else [])


def _proc_stat_busy() -> float:
    """Return the busy jiffies of all CPUs since boot."""
    fields = [float(v) for v in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    return sum(fields) - fields[3] - fields[4]  # not idle, not iowait


def run_child(command: list[str], prefix: list[str] | None = None) -> dict[str, Any]:
    """Run one child build; add the machine load and the CPU others used meanwhile."""
    before_load = os.getloadavg()
    uptime_before = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    busy0 = _proc_stat_busy()
    own0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    tick = time.perf_counter()
    done = subprocess.run([*(prefix or []), *command], capture_output=True, text=True)
    wall = time.perf_counter() - tick
    if done.returncode != 0:
        raise RuntimeError(f"{command} failed:\n{done.stderr[-3000:]}")
    busy1 = _proc_stat_busy()
    own1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    own_cpu = (own1.ru_utime - own0.ru_utime) + (own1.ru_stime - own0.ru_stime)
    hz = os.sysconf("SC_CLK_TCK")
    machine_cpu = (busy1 - busy0) / hz
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    result: dict[str, Any] = json.loads(lines[-1])  # py-spy also prints to stdout
    result["process_wall_s"] = round(wall, 1)
    result["cpu_s_this_run"] = round(own_cpu, 1)
    result["cpu_cores_used_by_others"] = round(max(0.0, machine_cpu - own_cpu) / wall, 2)
    result["loadavg_before"] = [round(v, 2) for v in before_load]
    result["loadavg_after"] = [round(v, 2) for v in os.getloadavg()]
    result["uptime_before"] = uptime_before
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
        "setup": "spot 30 mm, J750 grid, --workers 2, --thickness 0.5,0.5, --no-shell-meshes; "
        "A = --no-materials --format tiff,vdb; B = --format tiff,vdb,gcvf; C = B + png",
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


def reparse(args: argparse.Namespace) -> dict[str, Any]:
    """Parse the kept py-spy files again (after a change of the categories)."""
    stored = json.loads(RESULTS.read_text())["profile"]
    for variant in ("A", "B"):
        kept = HERE / "results" / f"bench_materials_build_pyspy_{variant}.txt.gz"
        raw = Path(tempfile.mkdtemp()) / "raw.txt"
        raw.write_bytes(gzip.decompress(kept.read_bytes()))
        run = stored["runs"][variant]
        stored["runs"][variant] = {"build": run["build"], **parse_raw(raw, stored["rate_hz"])}
        shutil.rmtree(raw.parent)
    a = stored["runs"]["A"]["sampled_s_by_part"]
    b = stored["runs"]["B"]["sampled_s_by_part"]
    extra = {k: round(b.get(k, 0.0) - a.get(k, 0.0), 1) for k in {*a, *b}}
    stored["B_minus_A_sampled_s"] = dict(sorted(extra.items(), key=lambda kv: -abs(kv[1])))
    stored.pop("B_minus_A_cpu_s", None)
    stored["note"] = (
        "py-spy samples of running or runnable threads (not idle) at rate_hz over the "
        "process tree; on the shared machine these exceed CPU time (compare sampled_s_total "
        "with build.cpu_s_this_run); see 'cpu' for CPU time per part"
    )
    return cast(dict[str, Any], stored)


def profile(args: argparse.Namespace) -> dict[str, Any]:
    rate = args.rate
    results: dict[str, Any] = {"rate_hz": rate, "runs": {}}
    folder = Path(tempfile.mkdtemp(prefix="pyspy-"))
    for variant in ("A", "B"):
        raw = folder / f"{variant}.txt"
        prefix = [
            str(PY_SPY), "record", "--subprocesses", "--threads", "--nonblocking",
            "--format", "raw", "--rate", str(rate), "-o", str(raw), "--",
        ]  # fmt: skip
        run = run_child(_child_command(args, variant, workers=args.workers), prefix=prefix)
        parsed = parse_raw(raw, rate)
        results["runs"][variant] = {"build": run, **parsed}
        print(variant, _brief(run), json.dumps(parsed["sampled_s_by_part"]), flush=True)
        kept = HERE / "results" / f"bench_materials_build_pyspy_{variant}.txt.gz"
        kept.write_bytes(gzip.compress(raw.read_bytes()))  # for ``reparse``
    a = results["runs"]["A"]["sampled_s_by_part"]
    b = results["runs"]["B"]["sampled_s_by_part"]
    extra = {k: round(b.get(k, 0.0) - a.get(k, 0.0), 1) for k in {*a, *b}}
    results["B_minus_A_sampled_s"] = dict(sorted(extra.items(), key=lambda kv: -abs(kv[1])))
    shutil.rmtree(folder)
    return results


def cpu(args: argparse.Namespace) -> dict[str, Any]:
    """CPU time per part of A and B with one worker (everything in one process)."""
    runs = {}
    for variant in ("A", "B"):
        run = run_child(_child_command(args, variant, workers=1, instrument=True))
        runs[variant] = run
        print(variant, _brief(run), json.dumps(run["cpu_s_by_part"]), flush=True)
    a, b = runs["A"]["cpu_s_by_part"], runs["B"]["cpu_s_by_part"]
    extra = {
        key: round(b.get(key, {}).get("cpu_s", 0.0) - a.get(key, {}).get("cpu_s", 0.0), 2)
        for key in {*a, *b}
    }
    return {
        "setup": "as overhead, but --workers 1 (slabs in the calling process); CPU seconds "
        "(time.thread_time) of each wrapped part, summed over its threads",
        "runs": runs,
        "B_minus_A_cpu_s": dict(sorted(extra.items(), key=lambda kv: -abs(kv[1]))),
        "B_minus_A_process_cpu_s": round(
            runs["B"]["process_cpu_s"] - runs["A"]["process_cpu_s"], 2
        ),
    }


def memory(args: argparse.Namespace) -> dict[str, Any]:
    runs = []
    for stretch in (1.0, 2.0):
        run = run_child(
            _child_command(args, "B", stretch_z=stretch, slab_mb=args.slab_mb, workers=2)
        )
        runs.append(run)
        print(stretch, _brief(run), flush=True)
    return {
        "setup": f"B (materials, tiff+vdb+gcvf), spot 30 mm and stretched 2x in z, 2 workers, "
        f"--slab-mb {args.slab_mb}, --thickness 0.5,0.5, --no-shell-meshes; peak RSS summed "
        "over the process tree, sampled every 50 ms",
        "runs": runs,
        "rss_ratio_2x_tall": round(runs[1]["peak_rss_tree_mb"] / runs[0]["peak_rss_tree_mb"], 3),
    }


def report(args: argparse.Namespace) -> dict[str, Any]:
    cases = [
        ("spot", 30.0, "rule"),
        ("duck", 30.0, "rule"),
        ("airplane", 30.0, "rule"),
        ("colour_target", 0.0, "rule"),
        ("colour_target", 0.0, "0.5,0.5"),
    ]
    results: dict[str, Any] = {
        "setup": "J750 grid, CLI default formats (tiff, vdb, gcvf), 2 workers, "
        "--no-shell-meshes, default material settings, 20000 report samples"
    }
    for model, size, thickness in cases:
        run = run_child(
            _child_command(args, "auto", model=model, size_mm=size, thickness=thickness,
                           full=True)
        )  # fmt: skip
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
        "from shellvox.config import MaterialSettings\n"
        "from shellvox.printer._material_plan import build_material_plan\n"
        "from shellvox.printer._profile import load_profile\n"
        "from shellvox.voxel.colour._materials import materials_for_slab\n"
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
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": cache}
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
    results["loadavg"] = [round(v, 2) for v in os.getloadavg()]
    results["note"] = (
        "each forked slab worker makes its own first call (the plan is built in the parent "
        "before the fork, the kernel is first called in the workers)"
    )
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "task",
        choices=["overhead", "profile", "reparse", "cpu", "memory", "report", "compile", "child"],
    )
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--png", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--rate", type=int, default=25, help="py-spy samples per second")
    parser.add_argument("--tmp", help="folder for the builds' temporary outputs")
    parser.add_argument("--key", help="result key (default: the task)")
    # child options
    parser.add_argument("--variant", choices=sorted(VARIANTS), default="B")
    parser.add_argument("--model", choices=sorted(ALL_MODELS), default="spot")
    parser.add_argument("--size-mm", type=float, default=30.0, help="0: the file's own size")
    parser.add_argument("--stretch-z", type=float, default=1.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--slab-mb", type=float, default=512.0)
    parser.add_argument("--thickness", default="0.5,0.5", help="'rule': the default rule")
    parser.add_argument("--full", action="store_true", help="child: colour report etc. too")
    parser.add_argument("--instrument", action="store_true", help="child: CPU time per part")
    args = parser.parse_args()
    if args.task == "child":
        print(json.dumps(child(args)))
        return
    if args.task == "memory" and args.slab_mb == 512.0:
        args.slab_mb = 256.0
    tasks = {
        "overhead": overhead,
        "profile": profile,
        "reparse": reparse,
        "cpu": cpu,
        "memory": memory,
        "report": report,
        "compile": compile_cost,
    }
    started = time.perf_counter()
    result = tasks[args.task](args)
    result["bench_seconds"] = round(time.perf_counter() - started, 1)
    result["commit"] = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    lock_path = Path(tempfile.gettempdir()) / "bench_materials_build.lock"
    with open(lock_path, "w") as lock:  # parts may run side by side
        fcntl.flock(lock, fcntl.LOCK_EX)
        everything = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        everything[args.key or args.task] = result
        RESULTS.write_text(json.dumps(everything, indent=1) + "\n")
    print(f"wrote {RESULTS} [{args.key or args.task}] in {result['bench_seconds']} s")


if __name__ == "__main__":
    main()
