"""The ``--method`` option of every command that offsets shells, read from the registry."""

from __future__ import annotations

import argparse

from shellvox.offset import DEFAULT_METHOD, METHODS


def add_method_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--method`` (choices and help from :data:`shellvox.offset.METHODS`)."""
    described = "; ".join(f"{m.name}: {m.summary}" for m in METHODS.values())
    parser.add_argument(
        "--method",
        choices=tuple(METHODS),
        default=DEFAULT_METHOD,
        help=f"offset construction of {what} (default {DEFAULT_METHOD}; {described})",
    )
