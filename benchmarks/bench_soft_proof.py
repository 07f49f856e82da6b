"""What the soft proof costs a default build, and what its picture costs ``inspect``.

    python benchmarks/bench_soft_proof.py

Builds spot at 30 mm (largest side) with ``shellvox build MODEL --printer j750`` twice
per round, five rounds, each build a child process, in alternating order: the default
(the soft proof's density, 12 surface samples per mm^2) and ``--proof-density 0`` (the
colour report's 20,000 samples alone: what the build needs without the proof's extra
samples). That build still writes ``proof.ply``, so the file's own cost is timed apart:
:func:`shellvox.output.write_proof_ply` of the default build's proof, read back, five
times. What the proof adds is the median wall-time difference plus that write, over the
report-only build's median. Then ``shellvox inspect`` on the default build, with its
``soft_proof.png`` and without it (the other previews alone), for the picture's cost.
The peer is the same build without the proof, in the same run.
"""

from __future__ import annotations

import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import mesh_path, parser, scale_for, write_result

NAME = "bench_soft_proof"
WHAT = (
    "Wall time of a default J750 build of spot at 30 mm with the soft proof's samples "
    "against the same build with the colour report's samples only (same run), and of "
    "inspect with and without soft_proof.png."
)


def _build(out: Path, density: float | None, quick: bool) -> tuple[float, dict[str, Any]]:
    command = [
        sys.executable, "-m", "shellvox.cli", "build", str(mesh_path("spot")),
        "--printer", "j750", "--no-progress", "-o", str(out),
        "--scale", repr(scale_for("spot", 30.0)),
    ]  # fmt: skip
    if density is not None:
        command += ["--proof-density", repr(density)]
    if quick:
        command += ["--voxel-size", "0.1,0.1,0.1", "--format", "tiff"]
    tick = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    seconds = time.perf_counter() - tick
    return seconds, json.loads((out / "manifest.json").read_text())


def _inspect(folder: Path) -> float:
    tick = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "shellvox.cli", "inspect", str(folder)],
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - tick


def main() -> None:
    args = parser(__doc__).parse_args()
    rounds = 1 if args.quick else 5
    times: dict[str, list[float]] = {"proof": [], "report_only": []}
    stages: dict[str, list[float]] = {"proof": [], "report_only": []}
    samples: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        _build(root / "warm", None, args.quick)  # kernels compiled, caches warm
        for round_ in range(rounds):
            order = ["proof", "report_only"] if round_ % 2 == 0 else ["report_only", "proof"]
            for name in order:
                out = root / name
                shutil.rmtree(out, ignore_errors=True)
                seconds, manifest = _build(out, None if name == "proof" else 0.0, args.quick)
                times[name].append(seconds)
                stages[name].append(manifest["seconds"].get("colour_report", 0.0))
                samples[name] = manifest["proof"]["samples"]
                print(name, f"{seconds:.1f} s", samples[name], "samples", flush=True)
        from shellvox.output import read_proof_ply, write_proof_ply

        proof = read_proof_ply(root / "proof" / "proof.ply")
        writes = []
        for _ in range(5):
            tick = time.perf_counter()
            write_proof_ply(root / "written.ply", proof)
            writes.append(time.perf_counter() - tick)
        write_s = statistics.median(writes)
        with_picture = _inspect(root / "proof")
        (root / "proof" / "proof.ply").rename(root / "proof.ply")  # the same build without
        manifest_path = root / "proof" / "manifest.json"
        manifest = json.loads(manifest_path.read_text())
        kept = dict(manifest)
        manifest.pop("proof")
        manifest["files"].pop("proof.ply")
        manifest_path.write_text(json.dumps(manifest))
        without_picture = _inspect(root / "proof")
        manifest_path.write_text(json.dumps(kept))
    proof, report_only = statistics.median(times["proof"]), statistics.median(times["report_only"])
    added = (proof - report_only + write_s) / report_only
    summary = [
        {
            "build": name,
            "samples": samples[name],
            "wall_s_median": round(statistics.median(times[name]), 2),
            "colour_report_stage_s_median": round(statistics.median(stages[name]), 2),
        }
        for name in ("proof", "report_only")
    ]
    details = {
        "setup": "shellvox build spot --printer j750 --scale S (largest side 30 mm), "
        "default vs --proof-density 0, alternating, after one warm-up build",
        "wall_s": times,
        "colour_report_stage_s": stages,
        "proof_ply_write_s": write_s,
        "added_by_proof": round(added, 4),
        "spread_s": {name: [min(t), max(t)] for name, t in times.items()},
        "inspect_s": {"with_soft_proof": with_picture, "without": without_picture},
    }
    print(f"the proof adds {100 * added:.1f} % to the build (proof.ply: {write_s:.3f} s)")
    path = write_result(
        NAME, {"what": WHAT, "summary": summary, "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
