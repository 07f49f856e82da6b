"""The documentation covers the package and says no more than is true.

Every public name of ``shellvox`` is in the API reference, every public function has an
example; the exit statuses page lists
the statuses :mod:`shellvox.faults` defines; the README stays short and its Python example
runs; no page, README or docstring tells the project's history (CHANGELOG.md does).
"""

from __future__ import annotations

import ast
import builtins
import doctest
import inspect
import re
from pathlib import Path

import pytest
from test_layout import MODULES

import shellvox
from shellvox import faults

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: Wording that tells history rather than what the code does.
HISTORY = re.compile(
    r"\b(stop \d+|issue \d+|until this|this stop|previously|was \d+ lines|retired)",
    re.IGNORECASE,
)


def test_every_public_name_is_in_the_api_reference():
    page = (DOCS / "reference" / "api.md").read_text(encoding="utf-8")
    named = set(re.findall(r"shellvox\.([A-Za-z_]+)", page))
    missing = sorted(set(shellvox.__all__) - named - {"__version__", "data"})
    assert missing == []


def test_every_public_function_has_an_example():
    # the examples run in tests/test_doctests.py and in `make docs`
    functions = [
        name for name in shellvox.__all__ if inspect.isfunction(getattr(shellvox, name, None))
    ]
    assert len(functions) > 10
    missing = [n for n in functions if ">>>" not in (inspect.getdoc(getattr(shellvox, n)) or "")]
    assert missing == []


def test_the_exit_statuses_page_lists_every_status():
    page = (DOCS / "reference" / "exit-statuses.md").read_text(encoding="utf-8")
    listed = {int(n) for n in re.findall(r"^\| (\d+) \|", page, re.M)}
    defined = {getattr(faults, name) for name in dir(faults) if name.startswith("EXIT_")}
    assert listed >= defined


def test_the_cli_reference_is_the_parser():
    page = (DOCS / "reference" / "cli.md").read_text(encoding="utf-8")
    assert ":module: shellvox.cli" in page and ":func: parser" in page
    import shellvox.cli

    help_text = shellvox.cli.parser().format_help()
    assert all(c in help_text for c in ("build", "shells", "fdm", "calibrate"))


def test_the_readme_is_short_and_starts_with_the_two_commands():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 150
    assert lines[3].startswith("make demo") and lines[4].startswith("make test")


def _texts() -> dict[str, str]:
    texts = {"README.md": (ROOT / "README.md").read_text(encoding="utf-8")}
    for path in sorted(DOCS.rglob("*.md")):
        if "_build" not in path.parts and "_generated" not in path.parts:
            texts[str(path.relative_to(ROOT))] = path.read_text(encoding="utf-8")
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef):
                doc = ast.get_docstring(node)
                if doc:
                    texts[f"{name}:{getattr(node, 'name', '')}"] = doc
    return texts


def test_no_history_in_the_readme_the_docs_or_the_docstrings():
    told = {
        where: match.group(0)
        for where, text in _texts().items()
        if (match := HISTORY.search(text)) is not None
    }
    assert told == {}


def test_the_history_check_catches_history():
    assert HISTORY.search("Until this stop each leaf was a dynamic block")
    assert HISTORY.search("the hand-written decoder is retired")
    assert not HISTORY.search("each leaf is one block of fixed codes")


@pytest.mark.slow
def test_the_readme_python_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    example = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    exec(compile(example, "README.md", "exec"), {})
    assert (tmp_path / "out" / "python" / "manifest.json").is_file()


#: A path of the source repository or of the files beside it, which an installed package
#: does not have: ``../shared/...``, or a file under the folders ``pipeline/``,
#: ``offset/`` or ``voxel/`` (the package names them ``shellvox``, ``shellvox.offset`` and
#: ``shellvox.voxel``; ``shellvox/printer/...`` or ``docs/x.md`` of another project pass).
REPO_PATH = re.compile(r"\.\./shared\b|(?<![\w./-])(?:pipeline|offset|voxel)/[\w*.]")
#: A private name used in an example: ``_name`` or ``module._name`` (not ``__dunder__``).
PRIVATE = re.compile(r"(?<![\w.])_[A-Za-z]\w*|\._[A-Za-z]\w*")


def _shipped_texts() -> dict[str, str]:
    """The pages, the docstrings, the ``#:`` comments autodoc renders, the shipped TOML files."""
    texts = {k: v for k, v in _texts().items() if k != "README.md"}  # the README: the repo's
    for name, path in MODULES.items():
        lines = path.read_text(encoding="utf-8").splitlines()
        texts[f"{name} #:"] = "\n".join(s for s in lines if s.lstrip().startswith("#:"))
    for path in sorted({*ROOT.glob("pipeline/**/*.toml"), *ROOT.glob("data/**/*.toml")}):
        texts[str(path.relative_to(ROOT))] = path.read_text(encoding="utf-8")
    return texts


def test_no_page_docstring_or_shipped_file_names_a_path_outside_the_package():
    named = {
        where: match.group(0)
        for where, text in _shipped_texts().items()
        if (match := REPO_PATH.search(text)) is not None
    }
    assert named == {}


def test_the_path_check_catches_repository_paths():
    for text in (
        "see ../shared/printing/voxel-print-facts.md",
        "Copy pipeline/printer/profiles/generic-cmykw.toml",
        "(`voxel/colour/_optics.py`)",
        "in ``offset/methods.py``",
        "the folder pipeline/printer/profiles",
    ):
        assert REPO_PATH.search(text), text
    for text in (
        "shellvox.voxel.colour and :mod:`shellvox.offset`",
        "resources of shellvox/printer/profiles",
        "iwaag/vdbmat-utils docs/print-slices.md",
        "https://example.org/voxel/",
    ):
        assert not REPO_PATH.search(text), text


def _documented() -> dict[str, object]:
    """Every public name of ``shellvox`` and ``shellvox.data``, and their classes' members."""
    found: dict[str, object] = {}
    names = [(f"shellvox.{n}", getattr(shellvox, n)) for n in shellvox.__all__ if n != "data"]
    names += [(f"shellvox.data.{n}", getattr(shellvox.data, n)) for n in shellvox.data.__all__]
    for name, value in names:
        found[name] = value
        if inspect.isclass(value):
            for member, attr in vars(value).items():
                if not member.startswith("_"):
                    found[f"{name}.{member}"] = attr
    return found


def _example_code(obj: object) -> list[str]:
    doc = inspect.getdoc(obj) if not isinstance(obj, str | int | float | tuple) else None
    if not doc or ">>>" not in doc:
        return []
    examples = doctest.DocTestParser().get_examples(doc)
    return [e.source for e in examples if not e.options.get(doctest.SKIP)]


def _undefined(sources: list[str]) -> set[str]:
    """Return the names `sources` (one example's statements) use without defining them."""
    defined: set[str] = set(dir(builtins))
    used: set[str] = set()
    for source in sources:
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Name):
                (used if isinstance(node.ctx, ast.Load) else defined).add(node.id)
            elif isinstance(node, ast.Import | ast.ImportFrom):
                defined |= {(a.asname or a.name).split(".")[0] for a in node.names}
            elif isinstance(node, ast.FunctionDef | ast.ClassDef):
                defined.add(node.name)
            elif isinstance(node, ast.arg):
                defined.add(node.arg)
    return used - defined


def test_the_public_examples_are_self_contained_and_public():
    # what `help()` and the API reference show: each example imports what it uses (a
    # user copies it into a fresh interpreter) and calls no private name
    documented = _documented()
    assert len(documented) > 50
    undefined, private = {}, {}
    for name, obj in documented.items():
        code = _example_code(obj)
        if missing := _undefined(code):
            undefined[name] = sorted(missing)
        if used := sorted({m.group(0) for s in code for m in PRIVATE.finditer(s)}):
            private[name] = used
    assert undefined == {}
    assert private == {}


def test_no_example_of_a_public_name_anywhere_calls_a_private_name():
    private = {}
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef):
                if getattr(node, "name", "").startswith("_"):
                    continue  # a private function's own example may call it
                doc = ast.get_docstring(node) or ""
                code = [e.source for e in doctest.DocTestParser().get_examples(doc)]
                if used := sorted({m.group(0) for s in code for m in PRIVATE.finditer(s)}):
                    private[f"{module}:{getattr(node, 'name', '')}"] = used
    assert private == {}


def test_the_example_checks_catch_what_they_look_for():
    assert _undefined(["mesh = load(path)\n", "np.ptp(mesh.vertices)\n"]) == {"load", "path", "np"}
    assert _undefined(["import numpy as np\n", "[np.sqrt(x) for x in range(3)]\n"]) == set()
    found = {m.group(0) for m in PRIVATE.finditer("from a._b import _demo; x._c(); f(__name__)")}
    assert found == {"._b", "_demo", "._c"}
