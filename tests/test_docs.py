"""The documentation covers the package and says no more than is true.

Every public name of ``shellvox`` is in the API reference, every public function has an
example; the exit statuses page lists
the statuses :mod:`shellvox.faults` defines; the README stays short and its Python example
runs; no page, README or docstring tells the project's history (CHANGELOG.md does).
"""

from __future__ import annotations

import ast
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
