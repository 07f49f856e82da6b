"""The "running" options of ``build``: where the slabs run, checkpoints, resume."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from shellvox.errors import InputError

if TYPE_CHECKING:
    from shellvox.run import RunSettings


def add_running_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the "running" group: where slabs run, checkpoints and resume."""
    running = parser.add_argument_group("running (where the slabs run; resume after a kill)")
    running.add_argument(
        "--scheduler",
        metavar="ADDRESS|local",
        help="compute the slabs on a Dask cluster: its scheduler's address (tcp://host:8786), "
        "or 'local' for a local cluster of --workers processes (default: this process "
        "and forked workers)",
    )
    running.add_argument(
        "--resume",
        action="store_true",
        help="continue the unfinished (killed) build in DIR: only its unfinished slabs are "
        "computed; refused when the model or options differ",
    )
    running.add_argument(
        "--checkpoint",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="keep finished slabs in DIR/.shellvox-run until the build is done, so that "
        "--resume can continue a killed build (default: for builds estimated to take "
        "over 10 minutes)",
    )


def running_from_args(args: argparse.Namespace) -> RunSettings:
    """Return the run settings of ``--scheduler``, ``--resume`` and ``--checkpoint``."""
    from shellvox.run import RunSettings

    scheduler = args.scheduler
    if scheduler is not None and not scheduler.strip():
        raise InputError("--scheduler", "got an empty address", "pass tcp://HOST:PORT or local")
    return RunSettings(scheduler=scheduler, resume=args.resume, checkpoint=args.checkpoint)
