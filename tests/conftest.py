"""Shared fixtures: the read-only real meshes in ../shared/meshes.

Where they are absent the tests that need them skip, and the summary says so in one
line; with the environment variable ``CI`` set (any value but empty) they fail instead,
so CI always runs the real-mesh tests (CI has ``shared/`` beside the checkout).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

SHARED_MESHES = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"
#: The skip reason of every test whose real mesh is absent (one summary line for all).
ABSENT = "the real test meshes are absent (../shared/meshes beside the checkout)"


def shared_path(relative: str) -> Path:
    """Return ``../shared/meshes/relative``; skip the test if it is absent (fail in CI)."""
    path = SHARED_MESHES / relative
    if not path.is_file():
        where = ABSENT if not SHARED_MESHES.is_dir() else f"{ABSENT}: {relative} is missing"
        if os.environ.get("CI"):
            pytest.fail(f"{where}; CI must run the real-mesh tests", pytrace=False)
        pytest.skip(where)
    return path


@pytest.fixture
def shared_mesh():
    """Return a function mapping a path inside ../shared/meshes to a Path, or skip."""
    return shared_path


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Say once how many tests skipped for want of the real meshes."""
    skipped = terminalreporter.stats.get("skipped", [])
    absent = [r for r in skipped if ABSENT in str(getattr(r, "longrepr", ""))]
    if absent:
        terminalreporter.write_line(
            f"shellvox: {len(absent)} tests skipped: {ABSENT}; set CI=1 to make them fail",
            yellow=True,
        )


@pytest.fixture(scope="session")
def real_mesh_shells():
    """Return a function ``(relative, size_mm) -> (mesh, shells, warnings)``, cached per run.

    The robust shells of a real mesh (thickness 0.5 and 1.0 mm, i.e. depths 0.5 and
    1.5 mm) take up to two minutes; several test modules check different properties of
    the same shells (as computed, and as written to PLY), so they are computed once.
    The mesh is loaded as the shell tests always did: merged by position, largest
    extent `size_mm`. ``warnings`` lists every warning raised while offsetting.
    """
    import warnings

    import trimesh

    from shellvox.offset import offset_shells

    cache: dict[tuple[str, float], tuple[object, list[object], list[warnings.WarningMessage]]] = {}

    def get(relative: str, size_mm: float):
        key = (relative, size_mm)
        if key not in cache:
            raw = trimesh.load(shared_path(relative), force="mesh")
            mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
            mesh.merge_vertices(merge_tex=True, merge_norm=True)
            mesh.apply_scale(size_mm / mesh.extents.max())
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                shells = offset_shells(mesh.vertices, mesh.faces, [0.5, 1.0], method="robust")
            cache[key] = (mesh, shells, list(caught))
        return cache[key]

    return get


@pytest.fixture(scope="session")
def small_colour_build(tmp_path_factory):
    """The default model built on a coarse grid (thickness rule, materials; TIFFs only).

    Read-only: a test that changes a build copies it first.
    """
    from shellvox.cli import main

    out = tmp_path_factory.mktemp("small_colour_build") / "build"
    model = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"
    argv = ["build", str(model), "-o", str(out), "--voxel-size", "0.2,0.2,0.15",
            "--format", "tiff", "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    return out


@pytest.fixture(scope="session")
def small_zarr_build(tmp_path_factory):
    """The default model on a coarse grid in slabs of 3 rows, TIFFs and the OME-Zarr store
    (materials; no colour report). Read-only: a test that changes it copies it first."""
    from shellvox.cli import main

    out = tmp_path_factory.mktemp("small_zarr_build") / "build"
    model = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"
    argv = ["build", str(model), "-o", str(out), "--voxel-size", "0.2,0.2,0.15",
            "--report-samples", "0", "--slab-mb", "2", "--format", "tiff,zarr",
            "--no-progress"]  # fmt: skip
    assert main(argv) == 0
    return out
