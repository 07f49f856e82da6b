"""No dead code: every function, class and method of the packages is used somewhere.

The walk reads every module of ``pipeline``, ``offset`` and ``voxel`` (and the tests and
benchmarks, which may be a function's only users: a reference kept for its test) with
:mod:`ast`, and collects each name that code *uses* (a load of a name or an attribute, an
import, an ``__all__`` entry, a string naming an attribute); a definition whose name is
never used is dead (what ``vulture`` reports at its 60 % confidence). Names that Python or
a framework calls by themselves (dunder methods, ``http.server``'s ``do_GET``) are not
counted.
"""

from __future__ import annotations

import ast
from pathlib import Path

from test_layout import MODULES, ROOT

#: Called by Python or by a base class, never by name in our code.
CALLED_BY_FRAMEWORK = {"do_GET", "do_HEAD", "do_POST", "log_message", "handle", "setup"}


def _sources() -> dict[Path, ast.Module]:
    paths = [*MODULES.values()]
    for folder in ("tests", "benchmarks"):
        paths += sorted((ROOT / folder).rglob("*.py"))
    return {path: ast.parse(path.read_text(encoding="utf-8")) for path in paths}


SOURCES = _sources()


def _used_names(trees) -> set[str]:
    used: set[str] = set()
    for tree in trees:
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and not isinstance(node.ctx, ast.Store):
                used.add(node.id)
            elif isinstance(node, ast.Attribute):
                used.add(node.attr)
            elif isinstance(node, ast.ImportFrom | ast.Import):
                used.update(alias.name.rpartition(".")[2] for alias in node.names)
            elif (
                isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and node.value.isidentifier()  # __all__, getattr(obj, "name"), registries
            ):
                used.add(node.value)
    return used


def _definitions(modules: dict[str, ast.Module]) -> list[tuple[str, str]]:
    found = []
    for name, tree in modules.items():
        for node in tree.body:
            if isinstance(node, ast.FunctionDef | ast.ClassDef):
                found.append((name, node.name))
            if isinstance(node, ast.ClassDef):
                found += [
                    (f"{name}.{node.name}", item.name)
                    for item in node.body
                    if isinstance(item, ast.FunctionDef)
                ]
    return found


def _dead(modules: dict[str, ast.Module], others: list[ast.Module]) -> list[str]:
    used = _used_names([*modules.values(), *others])
    return sorted(
        f"{where}.{name}"
        for where, name in _definitions(modules)
        if name not in used
        and not (name.startswith("__") and name.endswith("__"))
        and name not in CALLED_BY_FRAMEWORK
    )


def test_every_definition_is_used():
    modules = {name: SOURCES[path] for name, path in MODULES.items()}
    others = [tree for path, tree in SOURCES.items() if path not in MODULES.values()]
    assert _dead(modules, others) == []


def test_the_walk_finds_dead_code_and_counts_a_test_as_a_user():
    product = ast.parse(
        "class A:\n    def used(self):\n        return orphan\n\n    def unused(self):\n"
        "        pass\n\n    def __len__(self):\n        return 0\n\n\n"
        "def orphan():\n    return A().used()\n\n\ndef tested():\n    pass\n"
    )
    test = ast.parse("from m import tested\n")
    assert _dead({"m": product}, [test]) == ["m.A.unused"]
    assert _dead({"m": product}, []) == ["m.A.unused", "m.tested"]
