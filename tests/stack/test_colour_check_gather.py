"""The build's colour check gathers thin slabs into blocks before counting them.

A disc's rays are walked once per block they reach, so the check counts consecutive slabs
together; the counts themselves do not depend on the blocks
(``tests/voxel/colour/test_colour_report.py::test_slabs_give_the_same_counts_however_cut``).
Here: every row reaches the report once, in order, in blocks of at most the limit plus
one slab, the last block when the result is asked for.
"""

from __future__ import annotations

import itertools
from concurrent.futures import Future

import numpy as np

from shellvox.stack import _colour_check
from shellvox.stack._colour_check import ColourCheck


class _Recorder:
    def __init__(self) -> None:
        self.blocks: list[tuple[int, np.ndarray]] = []

    def add_slab(self, z_start: int, materials: np.ndarray) -> None:
        self.blocks.append((z_start, materials.copy()))


class _Columns:
    def __init__(self, report: _Recorder) -> None:
        self.report = report


def _check(recorder: _Recorder) -> ColourCheck:
    check = ColourCheck.__new__(ColourCheck)
    done: Future[_Columns] = Future()
    done.set_result(_Columns(recorder))  # type: ignore[arg-type]
    check._report = done  # type: ignore[assignment]
    check._gathered, check._gathered_start, check._gathered_end = [], 0, 0
    return check


def test_thin_slabs_reach_the_report_once_in_blocks(monkeypatch):
    monkeypatch.setattr(_colour_check, "GATHER_BYTES", 5 * 4 * 3)  # five rows of 4 x 3
    volume = np.random.default_rng(0).integers(0, 6, (23, 4, 3), dtype=np.uint8)
    recorder = _Recorder()
    check = _check(recorder)
    cuts = [0, 2, 3, 7, 9, 10, 16, 21, 23]
    for z0, z1 in itertools.pairwise(cuts):
        slab = volume[z0:z1].copy()
        check.add_slab(z0, slab)
        slab[:] = 255  # the caller may reuse its slab: the check kept its own rows
    check._count_gathered()  # as result() does first
    starts = [z for z, _ in recorder.blocks]
    rows = np.concatenate([block for _, block in recorder.blocks])
    np.testing.assert_array_equal(rows, volume)
    assert starts == sorted(starts) and len(starts) < len(cuts) - 1
    assert all(len(block) <= 5 + 6 for _, block in recorder.blocks)
    assert all(
        z == starts[0] + sum(len(b) for _, b in recorder.blocks[:k])
        for k, (z, _) in enumerate(recorder.blocks)
    )


def test_a_gap_between_slabs_flushes_the_block():
    volume = np.arange(10 * 2 * 2, dtype=np.uint8).reshape(10, 2, 2)
    recorder = _Recorder()
    check = _check(recorder)
    check.add_slab(0, volume[0:3])
    check.add_slab(5, volume[5:8])  # rows 3-4 never came (e.g. another worker's)
    check._count_gathered()
    assert [(z, len(b)) for z, b in recorder.blocks] == [(0, 3), (5, 3)]
