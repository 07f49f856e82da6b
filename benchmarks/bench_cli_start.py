"""How fast the command line starts: ``--version``, ``--help`` and every command's ``--help``.

Each is run as a new process of the installed ``shellvox`` entry point (the script beside
this Python; ``python -m shellvox.cli`` where there is none), as a person types it, and
timed from start to exit. The peer is ``python -c pass`` in the same run: the
interpreter's own start, below which no command can go. Rounds alternate: each round runs
every command once, so a busy moment of a shared machine falls on all of them alike; the
summary is the median of ``--repeat`` rounds (5), with the fastest and the slowest.

The claim: each of them under 0.5 s (the libraries a command needs load when it runs).

    python benchmarks/bench_cli_start.py [--repeat 5]
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from _common import load_average, parser, write_result

from shellvox.cli import COMMANDS

NAME = "bench_cli_start"
WHAT = (
    "Wall time of `shellvox --version`, `shellvox --help` and each `shellvox COMMAND --help` "
    "as new processes of the installed entry point (median of 5 rounds), against "
    "`python -c pass` in the same run."
)
#: What each command should stay under, s.
LIMIT_S = 0.5


def entry_point() -> list[str]:
    """Return the ``shellvox`` command: the installed script, else ``python -m shellvox.cli``."""
    script = Path(sys.executable).with_name("shellvox")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "shellvox.cli"]


def cases(quick: bool) -> dict[str, list[str]]:
    """Return each case's label and command line (the peer first)."""
    shellvox = entry_point()
    found = {
        "python -c pass": [sys.executable, "-c", "pass"],
        "shellvox --version": [*shellvox, "--version"],
        "shellvox --help": [*shellvox, "--help"],
    }
    for command in () if quick else COMMANDS:
        found[f"shellvox {command} --help"] = [*shellvox, command, "--help"]
    return found


def seconds(argv: list[str]) -> float:
    """Run `argv` to its end (output discarded); return the wall time, s."""
    start = time.perf_counter()
    done = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr.decode(errors='replace')}")
    return elapsed


def main() -> None:
    doc = (__doc__ or "").split("\n\n")[0]
    parsed = parser(doc)
    parsed.add_argument("--repeat", type=int, default=5, help="rounds (default 5)")
    args = parsed.parse_args()
    repeat = 1 if args.quick else args.repeat
    chosen = cases(args.quick)
    runs: dict[str, list[float]] = {label: [] for label in chosen}
    load_before = load_average()
    for argv in chosen.values():  # one untimed round: the files in the page cache
        seconds(argv)
    for _ in range(repeat):
        for label, argv in chosen.items():
            runs[label].append(round(seconds(argv), 4))
    peer = statistics.median(runs["python -c pass"])
    summary: list[dict[str, Any]] = []
    for label, times in runs.items():
        median = statistics.median(times)
        summary.append(
            {
                "command": label,
                "median_s": round(median, 3),
                "min_s": round(min(times), 3),
                "max_s": round(max(times), 3),
                "over_python_s": round(median - peer, 3),
                f"under_{LIMIT_S}_s": median < LIMIT_S,
            }
        )
    details = {
        "entry_point": entry_point(),
        "rounds": repeat,
        "runs_s": runs,
        "load_average": {"before": load_before, "after": load_average()},
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary, "details": details}, quick=args.quick
    )
    for row in summary:
        print(f"{row['command']:<28} median {row['median_s']:.3f} s  (min {row['min_s']:.3f})")
    print(path)


if __name__ == "__main__":
    main()
