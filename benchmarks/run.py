"""Run the benchmarks one after another, each in its own process; say where each result went.

    python benchmarks/run.py [NAME ...] [--list] [--quick]

A benchmark is a script ``benchmarks/bench_NAME.py``; NAME is ``bench_build`` or just
``build``; none: all of them, in alphabetical order (the full set takes hours on two
cores). Each writes ``benchmarks/results/bench_NAME.json``; with ``--quick`` each runs on
tiny inputs (seconds to a minute) and writes to ``out/bench-quick/`` instead, so a smoke
run never replaces a measured result. The test meshes come from ``$SHELLVOX_MESHES``
(default ``../shared/meshes`` beside the checkout).
"""

from __future__ import annotations

import argparse
import ast
import subprocess
import sys
import time
from pathlib import Path

from _common import QUICK_RESULTS, RESULTS, ROOT

HERE = Path(__file__).resolve().parent


def benchmarks() -> dict[str, Path]:
    """Return every benchmark script by name (``bench_*.py``), sorted."""
    return {path.stem: path for path in sorted(HERE.glob("bench_*.py"))}


def first_line(path: Path) -> str:
    """Return the first line of a script's docstring (what it measures)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    return doc.split("\n\n")[0].replace("\n", " ")


def chosen(names: list[str]) -> list[str]:
    """Return the benchmarks named (``bench_x`` or ``x``), all when none is; exit on a typo."""
    known = benchmarks()
    if not names:
        return list(known)
    picked = []
    for name in names:
        full = name if name in known else f"bench_{name}"
        if full not in known:
            raise SystemExit(f"no benchmark {name!r}; known: {', '.join(known)}")
        picked.append(full)
    return picked


def main() -> int:
    parsed = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parsed.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run (all)")
    parsed.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    parsed.add_argument("--quick", action="store_true", help="smoke runs to out/bench-quick/")
    args = parsed.parse_args()
    names = chosen(args.names)
    folder = QUICK_RESULTS if args.quick else RESULTS
    if args.list:
        for name in names:
            result = folder / f"{name}.json"
            state = "" if result.is_file() else " (no result yet)"
            print(f"{name}: {first_line(benchmarks()[name])}{state}")
        return 0
    failed = []
    for name in names:
        script = benchmarks()[name]
        command = [sys.executable, str(script), *(["--quick"] if args.quick else [])]
        result = folder / f"{name}.json"
        print(f"== {name}: {' '.join(['python', str(script.relative_to(ROOT)), *command[2:]])}")
        sys.stdout.flush()
        started = time.time()
        status = subprocess.run(command, cwd=ROOT, check=False).returncode
        minutes = (time.time() - started) / 60
        written = result.is_file() and result.stat().st_mtime >= started
        where = result.relative_to(ROOT) if written else "no result written"
        print(f"== {name}: exit status {status} after {minutes:.1f} min; {where}")
        if status != 0 or not written:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    print(f"{len(names)} benchmark(s) done; results in {folder.relative_to(ROOT)}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
