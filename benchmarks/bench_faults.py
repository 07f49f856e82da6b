"""Random-time SIGINT / SIGTERM / SIGKILL trials on a real build: the failure contract.

    nice python benchmarks/bench_faults.py [--trials 50] [--voxel-size 0.06]

Each trial: a fast build into a fresh folder (an older build to replace), then the
measured build into the same folder (``--voxel-size``, shell meshes on, 2 workers, slabs
of 16 MB so both workers run: about 30 s uninterrupted, measured first and recorded), a
signal to its main process at a uniformly random time within that duration (a third of
the trials each signal, shuffled), then the next (fast) build into the same folder. The
peer is the contract itself (every count should be 0). Counted:

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

Processes are found by scanning ``/proc`` (a run is started in a session of its own, so
its process group is its pid), with the tests' helpers in :mod:`shellvox.testing`.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import shutil
import signal
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import DEFAULT_MODEL, load_average, parser, write_result

from shellvox.testing import Command, holds_nothing, temporary_files, verified_files

NAME = "bench_faults"
WHAT = (
    "Random-time SIGINT, SIGTERM and SIGKILL during a real build: breaches of the "
    "failure contract (exit status, one error line, no traceback, no orphan process, "
    "no temporary or mixed files, the next build succeeds); the peer is the contract "
    "(every count 0)."
)
MODEL = DEFAULT_MODEL
EXPECTED = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -signal.SIGKILL}

#: A build of the default model that takes a few seconds (71 x 171 x 251 voxels).
FAST = (
    "--voxel-size", "0.1,0.1,0.1", "--workers", "2", "--slab-mb", "16",
    "--no-shell-meshes", "--no-progress",
)  # fmt: skip


def build_argv(out: Path, *extra: str) -> list[str]:
    """Return the arguments of a fast build of the default model into `out`."""
    return ["build", str(MODEL), "-o", str(out), *FAST, *extra]


# ------------------------------------------------------------------------------ trials


#: The measured build's shell option (``--quick``: none, the shell process takes ~20 s).
SHELLS = ["--shell-meshes"]


def measured_argv(out: Path, voxel: str) -> list[str]:
    return [
        "build", str(MODEL), "-o", str(out), "--voxel-size", voxel,
        "--workers", "2", "--slab-mb", "16", *SHELLS, "--no-progress",
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


def totals(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The counts over all trials (each should be 0 but ``finished_before_signal``)."""

    def count(key: str) -> int:
        return sum(1 for r in records if r.get(key))

    return {
        "trials": len(records),
        "by_signal": {k: sum(1 for r in records if r["signal"] == k) for k in SIGNALS},
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
            ((r["exit_after_signal_s"] or 0.0) for r in records if r["signal"] != "SIGKILL"),
            default=None,
        ),
    }


SIGNALS = ("SIGINT", "SIGTERM", "SIGKILL")


def summary(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per signal: its trials and the count of each breach of the contract."""
    rows = []
    for name in SIGNALS:
        mine = [r for r in records if r["signal"] == name]
        if not mine:
            continue
        row = totals(mine)
        del row["by_signal"], row["trials"]
        if name == "SIGKILL":  # no clean exit is promised: only exit, processes and next
            for key in ("not_one_line", "leftovers_after_signal", "folder_mixed_after_signal"):
                row[key] = None
            row["max_exit_after_signal_s"] = None
        rows.append({"signal": name, "trials": len(mine), **row})
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--trials", type=int, default=50)
    parsed.add_argument("--voxel-size", default="0.06", help="of the measured build (mm)")
    parsed.add_argument("--seed", type=int, default=9)
    args = parsed.parse_args()
    if args.quick:
        args.trials, args.voxel_size = 2, "0.2"
        SHELLS.clear()
    rng = random.Random(args.seed)
    root = Path(tempfile.mkdtemp(prefix="bench_faults."))
    started = time.time()
    load_start = load_average()
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
    details = {
        "measured_build": "shellvox build data/colour_target/colour_target.obj "
        f"--voxel-size {args.voxel_size} --workers 2 --slab-mb 16 {' '.join(SHELLS)} "
        "(signal to the main process)",
        "uninterrupted_s": [round(b, 1) for b in baseline],
        "signal_time": f"uniform in [0, {duration:.1f}] s after the start",
        "seed": args.seed,
        "load_average_1_5_15_min_at_start": load_start,
        "wall_minutes": round((time.time() - started) / 60, 1),
        "totals": totals(records),
        "trials": records,
    }
    print(json.dumps(details["totals"], indent=1))
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(records), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
