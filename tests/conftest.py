"""Shared fixtures: the read-only real meshes in ../shared/meshes (skipped when absent)."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED_MESHES = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"


@pytest.fixture
def shared_mesh():
    """Return a function mapping a path inside ../shared/meshes to a Path, or skip."""

    def get(relative: str) -> Path:
        path = SHARED_MESHES / relative
        if not path.is_file():
            pytest.skip(f"{path} is absent: the real test meshes live in ../shared/meshes")
        return path

    return get
