"""Running a build's job: the checkpoint default, the output folder's lock and the resume.

:func:`run_job` locks the output folder, opens the run folder of checkpoints
(:mod:`shellvox.run._checkpoints`) and runs the job in it; ``--resume`` without
checkpoints to resume says so in one line and builds from the start.
"""

from __future__ import annotations

import contextlib
import dataclasses
from pathlib import Path
from typing import Any, Protocol, cast

from shellvox.errors import warn
from shellvox.output import BuildFolder, OutputFolder
from shellvox.run import (
    CHECKPOINT_AFTER_S,
    JOURNAL,
    RUN_FOLDER,
    RunFolder,
    RunSettings,
    check_resumable,
    checkpoints,
)
from shellvox.stack._plan import BuildPlan


class Job(Protocol):
    """A build's job: a frozen dataclass with its run settings."""

    @property
    def running(self) -> RunSettings:
        """How the job runs (scheduler, checkpoints, resume)."""
        ...

    def run(self, folder: BuildFolder, run: RunFolder | None) -> dict[str, Any]:
        """Compute and write everything; return the manifest (not yet committed)."""
        ...


def settle_running(running: RunSettings | None, plan: BuildPlan) -> RunSettings:
    """Return the run settings with the checkpoint default decided by the estimate."""
    running = running or RunSettings()
    if running.checkpoint is None:
        checkpoint = plan.estimate.seconds > CHECKPOINT_AFTER_S
        running = dataclasses.replace(running, checkpoint=checkpoint)
    return running


def run_job(job: Job, out_dir: Path, key: dict[str, str], started: float) -> dict[str, Any]:
    """Run `job` in `out_dir` (locked, checkpointed as ``job.running`` says); the manifest.

    `key` names what the slabs depend on (:func:`shellvox.run._checkpoints.run_key`): a
    ``--resume`` whose key differs from the unfinished run's is refused before the lock,
    so the folder is left as it is.
    """
    if job.running.resume and not check_resumable(out_dir, key):
        warn(
            f"{out_dir}: no checkpoints to resume (no {RUN_FOLDER}/{JOURNAL}: the killed "
            "run wrote none, or this is a new folder); building from the start",
        )
        running = dataclasses.replace(job.running, resume=False, checkpoint=True)
        job = cast(Job, dataclasses.replace(cast(Any, job), running=running))
    with OutputFolder(out_dir) as locked, checkpoints(locked.path, key, job.running) as run:
        with contextlib.ExitStack() as stack:
            folder = BuildFolder(locked, stack, started)
            manifest = job.run(folder, run)
        return folder.commit(manifest)
