"""The ``shellvox`` command line: one module per subcommand, ``main(argv) -> int``.

Each subcommand module has ``add_arguments(parser)`` and ``run(args) -> int``. Bad input
(:class:`pipeline.errors.InputError`) becomes one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
import warnings
from collections.abc import Sequence
from types import ModuleType

from pipeline import __version__
from pipeline.errors import InputError, ShellvoxWarning, SlabWorkerDied

COMMANDS = ("info", "thickness", "shells", "build", "inspect")


def _subcommands() -> dict[str, ModuleType]:
    return {
        name: importlib.import_module(f"pipeline.cli.{name}")
        for name in COMMANDS
        if importlib.util.find_spec(f"pipeline.cli.{name}") is not None
    }


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shellvox",
        description="Per-face colour-layer shells and layered voxel stacks for colour 3D printing.",
    )
    parser.add_argument("--version", action="version", version=f"shellvox {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in _subcommands().items():
        doc = (module.__doc__ or "").strip().splitlines()[0]
        command = sub.add_parser(name, help=doc, description=doc)
        module.add_arguments(command)
        command.set_defaults(handler=module.run)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # type: ignore[no-untyped-def]
    print(f"shellvox: warning: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit status."""
    args = _parser().parse_args(argv)
    with warnings.catch_warnings():
        # Our own warnings are shown as one line each; library chatter is not.
        warnings.simplefilter("ignore")
        warnings.simplefilter("always", ShellvoxWarning)
        warnings.showwarning = _show_warning
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    try:
        status: int = args.handler(args)
        return status
    except InputError as error:
        print(f"shellvox: error: {error}", file=sys.stderr)
        return 2
    except SlabWorkerDied as error:
        print(f"shellvox: error: {error}; no partial output was kept", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("shellvox: interrupted; no partial output was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
