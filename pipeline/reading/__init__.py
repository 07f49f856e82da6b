"""A finished build as arrays: :func:`open_build` (lazily, from its OME-Zarr store)."""

from __future__ import annotations

from shellvox.reading._build import Build, Samples, open_build

__all__ = ["Build", "Samples", "open_build"]
