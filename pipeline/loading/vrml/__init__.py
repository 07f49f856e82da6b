"""VRML 2.0: the parser (:mod:`~shellvox.loading.vrml._parse`) and the reader."""

from __future__ import annotations

from shellvox.loading.vrml._parse import parse_vrml
from shellvox.loading.vrml._reader import read_vrml

__all__ = [
    "parse_vrml",
    "read_vrml",
]
