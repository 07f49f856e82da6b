"""Wavefront OBJ: the reader and the MTL material libraries it names."""

from __future__ import annotations

from shellvox.loading.obj._reader import read_obj

__all__ = [
    "read_obj",
]
