"""Every docstring example of the package runs, as its module is imported by users.

The examples are collected with :mod:`doctest` from each module of ``shellvox`` imported
by its own name (the folders are the package only through the build backend's mapping,
so pytest's ``--doctest-modules`` would import them a second time under the folders'
names). ``+SKIP`` examples are left out, as doctest does.
"""

from __future__ import annotations

import doctest
import importlib
import io
import pkgutil

import pytest

FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _modules() -> list[str]:
    """Every module of the package (its parts walked one by one: in an editable install
    shellvox.offset and shellvox.voxel are not folders of shellvox's folder)."""
    names = set()
    for part in ("shellvox", "shellvox.offset", "shellvox.voxel"):
        names.add(part)
        package = importlib.import_module(part)
        for info in pkgutil.walk_packages(package.__path__, f"{part}."):
            if not info.name.endswith("__main__"):
                names.add(info.name)
    return sorted(names)


def _examples(name: str) -> list[doctest.DocTest]:
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name, module=module)
    return [t for t in tests if any(not e.options.get(doctest.SKIP) for e in t.examples)]


MODULES = _modules()


def test_the_walk_finds_every_module():
    assert {"shellvox.voxel.grid", "shellvox.offset.shells", "shellvox.stack._plan"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    report = io.StringIO()
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in _examples(name):
        runner.run(test, out=report.write)
    assert runner.failures == 0, report.getvalue()
