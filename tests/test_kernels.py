"""Every compiled kernel is made by one decorator, with the options the README states.

Read two ways: the sources (no module but ``voxel/_compiled.py`` names numba's ``njit`` or
``jit``), and the compiled dispatchers themselves (each one found in every module of the
packages has ``cache``, ``nogil`` and numpy's error model in its target options).
"""

from __future__ import annotations

import ast
import importlib

import numba.core.registry
import pytest
from test_layout import MODULES

from shellvox.voxel._compiled import KERNEL_OPTIONS


def _numba_calls(path) -> list[str]:
    """Names of numba's compilers a module's source uses (attribute or imported name)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Attribute) and node.attr in ("njit", "jit", "generated_jit"):
            found.append(ast.unparse(node))
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("numba"):
            found += [alias.name for alias in node.names if alias.name in ("njit", "jit")]
    return found


def test_no_module_compiles_but_through_the_decorator():
    users = {
        name: calls
        for name, path in MODULES.items()
        if name != "shellvox.voxel._compiled" and (calls := _numba_calls(path))
    }
    assert users == {}


def test_the_decorator_is_what_the_walk_would_catch():
    assert _numba_calls(MODULES["shellvox.voxel._compiled"]) == ["numba.njit"]


def _options(dispatcher) -> dict:
    """The dispatcher's options as :data:`KERNEL_OPTIONS` names them (``cache`` is whether
    it has numba's on-disk cache)."""
    cached = type(dispatcher._cache).__name__ == "FunctionCache"
    return {
        "cache": cached,
        **{k: dispatcher.targetoptions.get(k) for k in ("nogil", "error_model")},
    }


def _dispatchers():
    for name in sorted(MODULES):
        if name.endswith("__main__"):
            continue
        module = importlib.import_module(name)
        for attribute, value in vars(module).items():
            if isinstance(value, numba.core.registry.CPUDispatcher):
                yield f"{name}.{attribute}", value


def test_every_kernel_has_the_stated_options():
    seen = dict(_dispatchers())
    assert len(seen) >= 40  # the walk finds the kernels (54 decorated functions)
    wrong = {
        name: options
        for name, dispatcher in seen.items()
        if (options := _options(dispatcher)) != KERNEL_OPTIONS
    }
    assert wrong == {}


@pytest.mark.parametrize("inline", ["never", "always"])
def test_inline_is_the_one_option_a_kernel_may_add(tmp_path, monkeypatch, inline):
    # numba caches only functions defined in a file: the kernel is written to one.
    (tmp_path / f"plus_one_{inline}.py").write_text(
        "from shellvox.voxel._compiled import kernel\n\n\n"
        f"@kernel(inline={inline!r})\ndef plus_one(x):\n    return x + 1\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    compiled = importlib.import_module(f"plus_one_{inline}").plus_one
    assert compiled(1) == 2
    assert compiled.targetoptions.get("inline", "never") == inline
    assert _options(compiled) == KERNEL_OPTIONS
