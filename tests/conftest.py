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

    from offset import offset_shells

    cache: dict[tuple[str, float], tuple[object, list[object], list[warnings.WarningMessage]]] = {}

    def get(relative: str, size_mm: float):
        key = (relative, size_mm)
        if key not in cache:
            path = SHARED_MESHES / relative
            if not path.is_file():
                pytest.skip(f"{path} is absent: the real test meshes live in ../shared/meshes")
            raw = trimesh.load(path, force="mesh")
            mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
            mesh.merge_vertices(merge_tex=True, merge_norm=True)
            mesh.apply_scale(size_mm / mesh.extents.max())
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                shells = offset_shells(mesh.vertices, mesh.faces, [0.5, 1.0])
            cache[key] = (mesh, shells, list(caught))
        return cache[key]

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
