"""Every public name resolves: each module's ``__all__`` and the lazy stub of ``shellvox``.

The modules are found by walking the installed package with :mod:`pkgutil` from each of
its roots (``package-dir`` in ``pyproject.toml``: an editable install maps ``shellvox.voxel``
and the others from folders beside ``pipeline/``, where a walk of ``shellvox`` alone would
not find them). A name listed in ``__all__`` that the module does not define makes
``from module import *`` raise ``AttributeError``; a name in ``pipeline/__init__.pyi``
(read by ``lazy_loader.attach_stub``) that does not resolve fails on first use.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import tomllib
from pathlib import Path

import shellvox

ROOT = Path(__file__).resolve().parents[1]
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
STUB = Path(shellvox.__file__).with_suffix(".pyi")


def _walk() -> dict[str, bool]:
    """Every module of the installed package (``__main__`` left out): name to is-package."""
    found: dict[str, bool] = {}
    errors: list[str] = []
    for root in sorted(SETUPTOOLS["package-dir"]):
        found[root] = True
        package = importlib.import_module(root)
        for info in pkgutil.walk_packages(package.__path__, f"{root}.", onerror=errors.append):
            found[info.name] = info.ispkg
    assert not errors, errors
    return {name: ispkg for name, ispkg in found.items() if name.rpartition(".")[2] != "__main__"}


MODULES = _walk()


def test_the_walk_finds_every_declared_package():
    regular = {
        name
        for name in SETUPTOOLS["packages"]
        if (spec := importlib.util.find_spec(name)) is not None and spec.origin is not None
    }
    walked = {name for name, ispkg in MODULES.items() if ispkg}
    assert regular <= walked, sorted(regular - walked)
    assert "shellvox.voxel.colour" in walked


def test_every_name_in_every_all_resolves():
    problems = []
    for name in sorted(MODULES):
        module = importlib.import_module(name)
        listed = getattr(module, "__all__", None)
        if listed is None:
            continue
        missing = [item for item in listed if not hasattr(module, item)]
        if missing:
            problems.append(f"{name}.__all__ lists names it does not define: {missing}")
            continue
        if len(set(listed)) != len(listed):
            problems.append(f"{name}.__all__ repeats a name")
        namespace: dict[str, object] = {}
        exec(f"from {name} import *", namespace)  # what a user's star import does
        if not set(listed) <= set(namespace):
            problems.append(f"from {name} import * misses {sorted(set(listed) - set(namespace))}")
    assert not problems, "\n".join(problems)


def _stub_names() -> tuple[set[str], list[str]]:
    """The names the stub imports and its ``__all__``, read with :mod:`ast`."""
    tree = ast.parse(STUB.read_text(encoding="utf-8"))
    imported: set[str] = set()
    listed: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            imported.update(alias.asname or alias.name for alias in node.names)
        elif isinstance(node, ast.Assign) and any(
            isinstance(target, ast.Name) and target.id == "__all__" for target in node.targets
        ):
            listed = list(ast.literal_eval(node.value))
    return imported, listed


def test_every_name_of_the_lazy_stub_resolves():
    imported, listed = _stub_names()
    assert imported, STUB
    missing = sorted(name for name in imported | set(listed) if not hasattr(shellvox, name))
    assert not missing, f"names of {STUB.name} that shellvox does not resolve: {missing}"
    # lazy_loader's __all__ is the stub's imports; the stub's own __all__ adds __version__
    assert set(shellvox.__all__) == imported == set(listed) - {"__version__"}
    namespace: dict[str, object] = {}
    exec("from shellvox import *", namespace)
    assert imported <= set(namespace)
