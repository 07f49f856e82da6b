"""Fuzz every loader through the CLI's error boundary (issue 22, item 5).

For each format, Hypothesis builds valid models (:mod:`fuzz_models`), damages them
(:mod:`fuzz_mutate`, :mod:`fuzz_tree`) and runs ``shellvox info`` on each in process
(:mod:`fuzz_oracle`): it must load (0) or refuse in one line (2), never fail inside
(1), print a traceback or run over 10 s, and an undamaged model must load. ``info`` is
the loaders' boundary; ``thickness`` and later steps are not run on the cases (see the
README).

Two profiles, chosen by the environment variable ``SHELLVOX_FUZZ``: ``short`` (the
default, in ``make test``: 60 cases per format, derandomized, no example database) and
``long`` (``make fuzz``: ``SHELLVOX_FUZZ_CASES`` cases per format, default 10,000,
seeded by ``SHELLVOX_FUZZ_SEED``). Failing cases are not shrunk: every one is copied,
with its description, to ``SHELLVOX_FUZZ_KEEP`` (default a temporary folder) and the
test fails at the end listing them; each line of counts is printed (and appended to
``SHELLVOX_FUZZ_REPORT`` if set). Known failures would be counted apart, not failed
(:data:`fuzz_oracle.KNOWN_FAILURES`, empty).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from fuzz_models import MODELS
from fuzz_oracle import Tally, run_info
from fuzz_tree import cases, damaged
from hypothesis import HealthCheck, Phase, given, seed, settings

LONG = os.environ.get("SHELLVOX_FUZZ", "short") == "long"
CASES = int(os.environ.get("SHELLVOX_FUZZ_CASES", "10000")) if LONG else 60
PROFILE = settings(
    max_examples=CASES,
    derandomize=not LONG,
    database=None,
    deadline=None,
    phases=(Phase.generate,),  # no shrinking: the failing cases are kept and listed instead
    suppress_health_check=list(HealthCheck),
)


@pytest.mark.parametrize("fmt", sorted(MODELS))
def test_fuzz_loader(fmt, tmp_path_factory, capsys):
    keep = Path(os.environ.get("SHELLVOX_FUZZ_KEEP") or tmp_path_factory.mktemp("kept"))
    keep.mkdir(parents=True, exist_ok=True)
    tally = Tally(fmt, keep)
    work = tmp_path_factory.mktemp(f"fuzz-{fmt}")

    @seed(int(os.environ.get("SHELLVOX_FUZZ_SEED", "0")))
    @PROFILE
    @given(case=cases(fmt))
    def run(case):
        model, ops = case
        folder = work / "case"
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir()
        path = damaged(model, ops).write(folder)
        outcome = run_info(path, valid=not ops)
        tally.add(folder, outcome, f"{model.name} {ops}")

    run()
    with capsys.disabled():  # the counts are the point of the run: shown, not captured
        print(f"\n{tally.line()}")
    if os.environ.get("SHELLVOX_FUZZ_REPORT"):
        with open(os.environ["SHELLVOX_FUZZ_REPORT"], "a") as report:
            print(tally.line(), *tally.failures, sep="\n", file=report)
    assert sum(tally.counts.values()) >= CASES * 0.9, tally.line()
    assert not tally.failures, "\n".join([tally.line(), *tally.failures])
