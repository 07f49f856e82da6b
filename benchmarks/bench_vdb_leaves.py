"""The VDB leaves' run encoder (``voxel/io/_deflate.py``) against zlib-ng's ``Z_RLE``.

The run grids of ``volume.vdb`` (``density``, ``layer``: float32 runs) compress each
8^3 leaf's active values as its own zlib stream. This builds a model with
``--format vdb --workers 1`` (in this process), records every batch of leaf buffers the
writer hands to :func:`shellvox.voxel.io._deflate.compress_segments`, then compresses the same
leaves, in the same run, with:

- ``run encoder``: ``compress_segments(raw, bounds, period=4)``, one compiled call a batch
  (what the writer does);
- ``zlib-ng Z_RLE``: ``zlib_ng.compressobj(1, DEFLATED, wbits, memLevel, Z_RLE)`` per leaf
  (a Python loop, as ``zipped`` does for the other grids), with zlib's default window and
  memory (15, 8) and with the smallest (9, 1), which Z_RLE (distance 1 only) does not need;
- ``zlib-ng 2``: the build's fast setting (``shellvox.voxel.io.compress``) per leaf, for reference.

Every stream is inflated with Python's zlib and compared with its leaf's bytes. Times
are the best of ``--repeat`` rounds, the encoders alternating within each round; MB/s
counts raw leaf bytes.

    .venv/bin/python benchmarks/bench_vdb_leaves.py [--printer j750] [--scale S] [MODEL]

Writes ``benchmarks/results/bench_vdb_leaves.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import tempfile
import time
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from zlib_ng import zlib_ng

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import shellvox.voxel.io.vdb._leaves as leaves_module  # noqa: E402
from shellvox.cli import main as shellvox  # noqa: E402
from shellvox.voxel.io import compress  # noqa: E402
from shellvox.voxel.io._deflate import compress_segments  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "bench_vdb_leaves.json"
MODEL = REPO / "data" / "colour_target" / "colour_target.obj"

Batch = tuple[NDArray[np.uint8], NDArray[np.int64]]


def record_leaves(model: Path, build_args: list[str]) -> list[Batch]:
    """Build `model` (vdb only, in this process); return the run grids' leaf batches."""
    batches: list[Batch] = []

    def spy(
        raw: NDArray[np.uint8], bounds: NDArray[np.int64], period: int = 1
    ) -> tuple[NDArray[np.uint8], NDArray[np.int64]]:
        batches.append((raw.copy(), np.asarray(bounds, np.int64).copy()))
        return compress_segments(raw, bounds, period)

    leaves_module.compress_segments = spy  # type: ignore[assignment]
    try:
        with tempfile.TemporaryDirectory() as folder:
            argv = ["build", str(model), "-o", f"{folder}/build", "--format", "vdb",
                    "--workers", "1", "--no-progress", *build_args]  # fmt: skip
            if shellvox(argv) != 0:
                raise SystemExit("the build failed")
    finally:
        leaves_module.compress_segments = compress_segments
    return batches


def per_leaf(encode: Callable[[memoryview], bytes]) -> Callable[[Batch], list[bytes]]:
    """Return an encoder of a batch that calls `encode` on each leaf (a Python loop)."""

    def run(batch: Batch) -> list[bytes]:
        raw, bounds = batch
        view = memoryview(raw)
        return [encode(view[a:b]) for a, b in itertools.pairwise(bounds.tolist())]

    return run


def z_rle(wbits: int, mem_level: int) -> Callable[[memoryview], bytes]:
    """zlib-ng's run-length strategy, one stream per call."""

    def encode(data: memoryview) -> bytes:
        compressor = zlib_ng.compressobj(1, zlib_ng.DEFLATED, wbits, mem_level, zlib_ng.Z_RLE)
        return compressor.compress(data) + compressor.flush()

    return encode


def run_encoder(batch: Batch) -> list[bytes]:
    """The compiled run encoder, as the writer calls it (one call a batch)."""
    raw, bounds = batch
    packed, lengths = compress_segments(raw, bounds, period=4)
    ends = np.cumsum(lengths)
    data = packed.tobytes()
    return [data[e - n : e] for e, n in zip(ends, lengths, strict=True)]


def check(batches: list[Batch], streams: list[list[bytes]]) -> None:
    """Raise unless every stream inflates (Python's zlib) to its leaf's bytes."""
    for (raw, bounds), packed in zip(batches, streams, strict=True):
        data = raw.tobytes()
        for (a, b), stream in zip(itertools.pairwise(bounds.tolist()), packed, strict=True):
            if zlib.decompress(stream) != data[a:b]:
                raise AssertionError("a stream does not inflate to its leaf")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", nargs="?", type=Path, default=MODEL)
    parser.add_argument("--printer", default="j750")
    parser.add_argument("--scale", type=float, default=None)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    build_args = ["--printer", args.printer]
    if args.scale is not None:
        build_args += ["--scale", str(args.scale)]
    tick = time.perf_counter()
    batches = record_leaves(args.model, build_args)
    build_s = time.perf_counter() - tick
    raw_bytes = sum(len(raw) for raw, _ in batches)
    n_leaves = sum(len(bounds) - 1 for _, bounds in batches)
    encoders: dict[str, Callable[[Batch], list[bytes]]] = {
        "run encoder (deflate.py)": run_encoder,
        "zlib-ng Z_RLE (wbits 15, memLevel 8)": per_leaf(z_rle(15, 8)),
        "zlib-ng Z_RLE (wbits 9, memLevel 1)": per_leaf(z_rle(9, 1)),
        "zlib-ng level 2 (the fast setting)": per_leaf(lambda d: compress(d)),
    }
    best = dict.fromkeys(encoders, float("inf"))
    sizes: dict[str, int] = {}
    for name, encode in encoders.items():  # compile, check, count bytes
        streams = [encode(batch) for batch in batches]
        check(batches, streams)
        sizes[name] = sum(len(s) for packed in streams for s in packed)
    for _ in range(args.repeat):
        for name, encode in encoders.items():
            tick = time.perf_counter()
            for batch in batches:
                encode(batch)
            best[name] = min(best[name], time.perf_counter() - tick)
    rows: dict[str, Any] = {}
    peer = best["run encoder (deflate.py)"]
    for name in encoders:
        rows[name] = {
            "seconds": round(best[name], 4),
            "MB_per_s": round(raw_bytes / best[name] / 1e6, 1),
            "us_per_leaf": round(1e6 * best[name] / n_leaves, 3),
            "bytes": sizes[name],
            "bytes / run encoder": round(sizes[name] / sizes["run encoder (deflate.py)"], 3),
            "time / run encoder": round(best[name] / peer, 3),
        }
        print(name, json.dumps(rows[name]))
    results = {
        "model": str(args.model.resolve().relative_to(REPO))
        if args.model.resolve().is_relative_to(REPO)
        else str(args.model),
        "build_args": build_args,
        "build_seconds": round(build_s, 1),
        "batches": len(batches),
        "leaves": n_leaves,
        "raw_bytes": raw_bytes,
        "repeat": args.repeat,
        "encoders": rows,
    }
    RESULTS.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
