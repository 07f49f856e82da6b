"""Random-time SIGINT / SIGTERM / SIGKILL trials on a real build (issue 9, done-when).

Usage (from the repository root)::

    nice .venv/bin/python benchmarks/bench_faults.py --trials 50

Each trial: a fast build into a fresh folder (an older build to replace), then the
measured build into the same folder (``--voxel-size``, shell meshes on, 2 workers, slabs
of 16 MB so both workers run: about 30 s uninterrupted, measured first and recorded), a
signal to its main process at a uniformly random time within that duration (a third of
the trials each signal, shuffled), then the next (fast) build into the same folder. Counted:

* ``orphans``: trials where a process of the run (its process group: slab workers, the
  shell process, multiprocessing's resource tracker) was alive 2 s after the main exited;
* ``tracebacks``: trials with ``Traceback`` in the interrupted run's stderr;
* ``leftovers_after_next``: trials whose folder held a temporary file after the next build;
* ``hangs``: trials whose main did not exit within 60 s of the signal;
* ``wrong_exit``: SIGINT not 130, SIGTERM not 143, SIGKILL not -9 (a run that finished
  before the signal may exit 0: then its folder must verify);
* also ``not_one_line`` (SIGINT/SIGTERM: not exactly one ``shellvox: error:`` line, or
  other stderr lines), ``leftovers_after_signal`` (SIGINT/SIGTERM: temporary files left),
  ``folder_mixed_after_signal`` (SIGINT/SIGTERM: the folder neither empty nor one whole
  build), ``next_failed`` (the next build did not succeed and verify).

Results go to ``benchmarks/results/bench_faults.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import random
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from fault_harness import (  # noqa: E402
    MODEL,
    Command,
    build_argv,
    holds_nothing,
    temporary_files,
    verified_files,
)

EXPECTED = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -signal.SIGKILL}


def measured_argv(out: Path, voxel: str) -> list[str]:
    return [
        "build", str(MODEL), "-o", str(out), "--voxel-size", voxel,
        "--workers", "2", "--slab-mb", "16", "--shell-meshes", "--no-progress",
    ]  # fmt: skip


def verifies(folder: Path) -> bool:
    try:
        verified_files(folder)
    except (AssertionError, OSError, ValueError, KeyError):
        return False
    return True


def clean_stderr(text: str) -> bool:
    lines = text.splitlines()
    errors = [x for x in lines if x.startswith("shellvox: error: ")]
    others = [x for x in lines if not x.startswith(("shellvox: error: ", "shellvox: grid "))]
    return len(errors) == 1 and not others


def trial(index: int, signum: int, delay: float, voxel: str, root: Path) -> dict[str, Any]:
    work = root / f"trial{index:02d}"
    out = work / "out"
    old = Command(build_argv(out, "--thickness", "0.4,0.4"), work / "old").finish(timeout=300)
    record: dict[str, Any] = {
        "trial": index,
        "signal": signal.Signals(signum).name,
        "delay_s": round(delay, 3),
        "old_build_ok": old.status == 0,
    }
    command = Command(measured_argv(out, voxel), work / "run")
    time.sleep(delay)
    with contextlib.suppress(ProcessLookupError):
        os.kill(command.pid, signum)
    result = command.finish(timeout=60, grace=2.0)  # kills the group after reporting it
    exited = result.seconds - delay  # main's exit, from the signal
    record.update(
        status=result.status,
        exit_after_signal_s=round(exited, 2) if result.status is not None else None,
        hang=result.status is None,
        orphans=[f"{p.pid} {p.cmdline[:100]}" for p in result.left],
        traceback="Traceback" in result.stderr,
        stderr_tail=result.stderr.strip().splitlines()[-3:],
    )
    finished = result.status == 0 and verifies(out)
    record["finished_before_signal"] = finished
    record["wrong_exit"] = not (result.status == EXPECTED[signum] or finished)
    if signum != signal.SIGKILL and not finished:
        record["not_one_line"] = not clean_stderr(result.stderr)
        leftover = temporary_files(out)
        record["leftovers_after_signal"] = [p.name for p in leftover]
        # one build or none: nothing (the old build went), or the old build whole (the
        # signal came before the run touched the folder), never a mix
        record["folder_after_signal"] = (
            "empty" if holds_nothing(out) else "a whole build" if verifies(out) else "mixed"
        )
    else:
        record["leftovers_after_kill"] = [p.name for p in temporary_files(out)]
    after = Command(build_argv(out), work / "next").finish(timeout=300)
    record["next_status"] = after.status
    record["leftovers_after_next"] = [p.name for p in temporary_files(out)]
    record["next_verifies"] = after.status == 0 and verifies(out) and not after.left
    shutil.rmtree(work, ignore_errors=True)
    return record


def _commit() -> str | None:
    """The code's commit: git's, or $SHELLVOX_COMMIT for an exported copy."""
    try:
        done = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return os.environ.get("SHELLVOX_COMMIT")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--voxel-size", default="0.06", help="of the measured build (mm)")
    parser.add_argument("--seed", type=int, default=9)
    parser.add_argument(
        "--output", type=Path, default=ROOT / "benchmarks" / "results" / "bench_faults.json"
    )
    args = parser.parse_args()
    rng = random.Random(args.seed)
    root = Path(tempfile.mkdtemp(prefix="bench_faults."))
    started = time.time()
    load_start = os.getloadavg()
    baseline = []
    for k in range(2):  # the uninterrupted duration of the measured build
        out = root / f"baseline{k}"
        tick = time.monotonic()
        done = Command(measured_argv(out, args.voxel_size), root / f"b{k}").finish(timeout=600)
        baseline.append(time.monotonic() - tick)
        assert done.status == 0 and verifies(out), done.stderr
    duration = statistics.median(baseline)
    kinds = [signal.SIGINT, signal.SIGTERM, signal.SIGKILL]
    signals = [kinds[i % 3] for i in range(args.trials)]
    rng.shuffle(signals)
    records = []
    for index, signum in enumerate(signals):
        delay = rng.uniform(0.0, duration)
        records.append(trial(index, signum, delay, args.voxel_size, root))
        print(json.dumps(records[-1]), flush=True)
    shutil.rmtree(root, ignore_errors=True)

    def count(key: str) -> int:
        return sum(1 for r in records if r.get(key))

    summary = {
        "trials": len(records),
        "by_signal": {k.name: signals.count(k) for k in kinds},
        "orphans": count("orphans"),
        "tracebacks": count("traceback"),
        "leftovers_after_next": count("leftovers_after_next"),
        "hangs": count("hang"),
        "wrong_exit": count("wrong_exit"),
        "not_one_line": count("not_one_line"),
        "leftovers_after_signal": count("leftovers_after_signal"),
        "folder_mixed_after_signal": sum(
            1 for r in records if r.get("folder_after_signal") == "mixed"
        ),
        "next_failed": sum(1 for r in records if not r["next_verifies"]),
        "finished_before_signal": count("finished_before_signal"),
        "max_exit_after_signal_s": max(
            (r["exit_after_signal_s"] or 0.0) for r in records if r["signal"] != "SIGKILL"
        ),
    }
    result = {
        "benchmark": "bench_faults",
        "command": "build data/colour_target/colour_target.obj --voxel-size "
        f"{args.voxel_size} --workers 2 --slab-mb 16 --shell-meshes (signal to the main process)",
        "uninterrupted_s": [round(b, 1) for b in baseline],
        "signal_time": f"uniform in [0, {duration:.1f}] s after the start",
        "seed": args.seed,
        "commit": _commit(),
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "load_average_1_5_15_min_at_start": [round(x, 2) for x in load_start],
            "load_average_1_5_15_min_at_end": [round(x, 2) for x in os.getloadavg()],
        },
        "wall_minutes": round((time.time() - started) / 60, 1),
        "summary": summary,
        "trials": records,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
