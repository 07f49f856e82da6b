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

zlib-ng's ``Z_RLE``, the library's own way of packing runs, is the peer.

Every stream is inflated with Python's zlib and compared with its leaf's bytes. Times
are the best of ``--repeat`` rounds, the encoders alternating within each round; MB/s
counts raw leaf bytes.

    python benchmarks/bench_vdb_leaves.py [--printer j750] [--scale S] [MODEL]
"""

from __future__ import annotations

import itertools
import json
import tempfile
import time
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from _common import DEFAULT_MODEL, ROOT, parser, write_result
from numpy.typing import NDArray
from zlib_ng import zlib_ng

import shellvox.voxel.io.vdb._leaves as leaves_module
from shellvox.cli import main as shellvox
from shellvox.voxel.io import compress
from shellvox.voxel.io._deflate import compress_segments

NAME = "bench_vdb_leaves"
WHAT = (
    "Time and bytes of the VDB leaves' run encoder (one compiled call a batch) on a "
    "build's own density and layer leaves, against zlib-ng's Z_RLE per leaf (and "
    "zlib-ng level 2 for reference), in the same run."
)
MODEL = DEFAULT_MODEL

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


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    return [
        {
            "encoder": name,
            "MB_per_s": row["MB_per_s"],
            "us_per_leaf": row["us_per_leaf"],
            "bytes": row["bytes"],
            "time_over_run_encoder": row["time / run encoder"],
            "bytes_over_run_encoder": row["bytes / run encoder"],
        }
        for name, row in details["encoders"].items()
    ]


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("model", nargs="?", type=Path, default=MODEL)
    parsed.add_argument("--printer", default="j750")
    parsed.add_argument("--scale", type=float, default=None)
    parsed.add_argument("--repeat", type=int, default=5)
    args = parsed.parse_args()
    build_args = ["--printer", args.printer]
    if args.scale is not None:
        build_args += ["--scale", str(args.scale)]
    if args.quick:
        build_args += ["--voxel-size", "0.1,0.1,0.1"]
        args.repeat = 1
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
        "model": str(args.model.resolve().relative_to(ROOT))
        if args.model.resolve().is_relative_to(ROOT)
        else str(args.model),
        "build_args": build_args,
        "build_seconds": round(build_s, 1),
        "batches": len(batches),
        "leaves": n_leaves,
        "raw_bytes": raw_bytes,
        "repeat": args.repeat,
        "encoders": rows,
    }
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(results), "details": results}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
