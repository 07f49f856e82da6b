"""The ``--method`` option of every command that offsets shells (:mod:`shellvox.cli.choices`)."""

from __future__ import annotations

import argparse

from shellvox.cli.choices import DEFAULT_METHOD, METHODS


def add_method_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--method`` (the methods of :data:`shellvox.offset.METHODS` and their summaries)."""
    described = "; ".join(f"{name}: {summary}" for name, summary in METHODS.items())
    parser.add_argument(
        "--method",
        choices=tuple(METHODS),
        default=DEFAULT_METHOD,
        help=f"offset construction of {what} (default {DEFAULT_METHOD}; {described})",
    )
