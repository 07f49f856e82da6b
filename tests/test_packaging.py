"""What the wheel holds: one import package, every subpackage, its data files.

``scripts/check_wheel.sh`` (``make wheel-check``, in CI) builds the wheel and installs it in
a fresh environment; these tests check the declaration it is built from.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import shellvox

ROOT = Path(__file__).resolve().parents[1]
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _folders() -> set[str]:
    found = set()
    for package, folder in SETUPTOOLS["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            parts = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join((package, *parts)))
    return found


def test_every_package_folder_is_declared_and_only_under_shellvox():
    declared = set(SETUPTOOLS["packages"])
    data_only = declared - _folders()
    assert _folders() <= declared
    assert data_only <= set(SETUPTOOLS["package-data"])  # folders of data files only
    assert {name.split(".")[0] for name in declared} == {"shellvox"}


def test_the_declared_data_files_exist():
    for package, patterns in SETUPTOOLS["package-data"].items():
        top = next(
            p
            for p in sorted(SETUPTOOLS["package-dir"], key=len, reverse=True)
            if package == p or package.startswith(p + ".")
        )
        folder = ROOT / SETUPTOOLS["package-dir"][top] / Path(*package[len(top) + 1 :].split("."))
        for pattern in patterns:
            assert list(folder.glob(pattern)), (package, pattern)


def test_the_bundled_files_are_found_through_the_package():
    assert shellvox.data.colour_target().is_file()
    assert shellvox.data.thickness_rule().is_file()
    assert SETUPTOOLS["dynamic"]["version"] == {"attr": "shellvox.__version__"}


def test_the_optional_imports_name_an_extra_that_installs_them(monkeypatch):
    # shellvox.testing's MeshLab checks without pymeshlab: the one-line error names the
    # extra, and that extra (read from pyproject.toml) is what brings pymeshlab
    from shellvox.testing import _meshlab

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = extras["optional-dependencies"]
    assert any(req.startswith("pymeshlab") for req in extras["testing"])
    assert any(req.startswith("distributed") for req in extras["cluster"])
    monkeypatch.setattr(_meshlab, "HAVE_PYMESHLAB", False)
    with pytest.raises(ModuleNotFoundError, match=r"pip install 'shellvox\[testing\]'"):
        _meshlab.meshlab_checks(ROOT / "pyproject.toml")
