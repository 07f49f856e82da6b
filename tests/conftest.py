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


@pytest.fixture(scope="session")
def small_colour_build(tmp_path_factory):
    """The default model built on a coarse grid (thickness rule, materials; TIFFs only).

    Read-only: a test that changes a build copies it first.
    """
    from pipeline.cli import main

    out = tmp_path_factory.mktemp("small_colour_build") / "build"
    model = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"
    argv = ["build", str(model), "-o", str(out), "--voxel-size", "0.2,0.2,0.15",
            "--format", "tiff", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    return out
