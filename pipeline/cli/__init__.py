"""The ``shellvox`` command line: one module per subcommand, ``main(argv) -> int``.

Each subcommand module has ``add_arguments(parser)`` and ``run(args) -> int``. The error
boundary here turns every failure into one line on stderr and a documented exit status
(:mod:`shellvox.faults`: 2 bad input, 3 disk, 4 memory, 130/143 interrupted, 1 a bug);
``--debug`` adds the traceback. SIGINT and SIGTERM stop the run cleanly (temporary files
removed, workers stopped) with one line.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import logging
import sys
import traceback
import warnings
from collections.abc import Sequence
from types import ModuleType
from typing import NoReturn

from shellvox import __version__
from shellvox.errors import InputError, ShellvoxWarning
from shellvox.faults import (
    EXIT_SIGINT,
    EXIT_SIGTERM,
    DeferredSignals,
    describe,
    signals_raise,
    unblock_signals,
)

COMMANDS = (
    "info", "thickness", "shells", "build", "fdm", "inspect", "view", "chart", "calibrate"
)  # fmt: skip


def _subcommands() -> dict[str, ModuleType]:
    return {
        name: importlib.import_module(f"shellvox.cli.{name}")
        for name in COMMANDS
        if importlib.util.find_spec(f"shellvox.cli.{name}") is not None
    }


def parser() -> argparse.ArgumentParser:
    """Return the command line's argument parser (every command and option; the CLI reference)."""
    top = _Parser(
        prog="shellvox",
        description="Per-face colour-layer shells and layered voxel stacks for colour 3D printing.",
    )
    top.add_argument("--version", action="version", version=f"shellvox {__version__}")
    top.add_argument(
        "--debug", action="store_true", help="show the traceback of a failure (for bug reports)"
    )
    sub = top.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in _subcommands().items():
        doc = (module.__doc__ or "").strip().splitlines()[0]
        command = sub.add_parser(name, help=doc, description=doc)
        module.add_arguments(command)
        command.set_defaults(handler=module.run)
    return top


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (``shellvox: error: ...``, exit 2)."""

    def error(self, message: str) -> NoReturn:
        raise InputError(None, message, f"see {self.prog} --help")


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # type: ignore[no-untyped-def]
    """Print a warning as one line, the options it names as the command line's flags."""
    words = getattr(message, "words", None)
    text = words("cli") if callable(words) else str(message)
    print(f"shellvox: warning: {text}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit status (see :mod:`shellvox.faults`).

    Run as the program (`argv` None) and stopped by a signal, without ``--debug``: the
    exceptions of finalisers as the process ends are dropped. A signal can stop a library
    mid-way (numba compiling a kernel), and the objects it left half made may fail to
    finalise; the run is stopped and said so in one line, their tracebacks would alarm.
    """
    program = argv is None
    argv = sys.argv[1:] if argv is None else list(argv)
    # Libraries' log records (tifffile logs a warning for a broken file) would go to
    # stderr through logging's last-resort handler: not without --debug.
    quiet = logging.NullHandler()
    if "--debug" not in argv:
        logging.getLogger().addHandler(quiet)
    try:
        with warnings.catch_warnings():
            # Our own warnings are shown as one line each; library chatter is not.
            warnings.simplefilter("ignore")
            warnings.simplefilter("always", ShellvoxWarning)
            warnings.showwarning = _show_warning
            status = _run(argv)
            if program and status in (EXIT_SIGINT, EXIT_SIGTERM) and "--debug" not in argv:
                sys.unraisablehook = _quiet_unraisable
            return status
    finally:
        logging.getLogger().removeHandler(quiet)


def _run(argv: list[str]) -> int:
    args: argparse.Namespace | None = None
    # The boundary holds from the first line: a signal during the imports of the
    # subcommands (seconds) is held back until they are done, then stops the run.
    with signals_raise():
        try:
            with DeferredSignals():
                arguments = parser()
            unblock_signals()  # blocked since the start by python -m shellvox.cli
            args = arguments.parse_args(argv)
            # offset's own warning class (offset cannot import pipeline), shown as ours are;
            # imported once the arguments are read: the parser and --help stay light
            from shellvox.offset.reference.robust import ShellDefectWarning

            warnings.simplefilter("always", ShellDefectWarning)
            status: int = args.handler(args)
            return status
        except (SystemExit, GeneratorExit):
            raise
        except BaseException as error:
            status, message = describe(error)
            if getattr(args, "debug", "--debug" in argv):
                traceback.print_exception(error, file=sys.stderr)
            print(f"shellvox: error: {message}", file=sys.stderr)
            return status


def _quiet_unraisable(unraisable: sys.UnraisableHookArgs) -> None:
    """Drop an exception raised where none can be (a finaliser), after an interruption."""
