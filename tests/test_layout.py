"""The layout of the packages: import rules, no import circles, sizes (issue 23).

The imports are read with :mod:`ast` from every module of ``pipeline``, ``voxel`` and
``offset`` (all of them, those under ``if TYPE_CHECKING`` and inside functions too), so a
rule broken by a lazy import counts.

The layers of ``pipeline``, bottom up (a module imports only its own layer and those below):

0. bottom: ``pipeline`` (the version), ``errors``, ``config``, ``faults``, ``atomic``
1. ``model`` (the coloured mesh, textures, topology)
2. ``loading``, ``thickness``, ``printer`` (side by side: none imports another)
3. ``output`` (the folder, the streams, the manifest and its checks, shells, PLY) and, beside
   it, ``fdm`` (the 3MF projects for FDM slicers, from the model, thickness and shells)
4. ``run`` (slab tasks and where they run)
5. ``build`` (one model's stack)
6. ``tray`` (several models, one job)
7. ``cli``

``report`` and ``viewer`` read an output folder: they import the bottom, ``output`` and
(``report``, for the stack pages) ``viewer``, and only ``cli`` imports them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("pipeline", "voxel", "offset")

LAYERS = {
    "pipeline": 0, "pipeline.errors": 0, "pipeline.config": 0, "pipeline.faults": 0,
    "pipeline.atomic": 0, "pipeline.model": 1, "pipeline.loading": 2, "pipeline.thickness": 2,
    "pipeline.printer": 2, "pipeline.output": 3, "pipeline.fdm": 3, "pipeline.run": 4,
    "pipeline.build": 5, "pipeline.tray": 6, "pipeline.cli": 7,
}  # fmt: skip
READERS = ("pipeline.report", "pipeline.viewer")
STAGES = ("model", "loading", "thickness", "printer", "output", "fdm", "run", "build", "tray",
          "report", "viewer", "cli")  # fmt: skip
MAX_TOP_MODULES = {"pipeline": 8, "voxel": 10}
MAX_LINES = 1000  # a sanity limit: modules are split by concept, not by a count
#: The one decorator of compiled kernels: every package may import it.
COMPILED = "voxel._compiled"


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """Return the project modules that module `name` imports (each resolved to a module)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([node.module] if node.module else [])])
            targets = [f"{base}.{alias.name}" for alias in node.names] + [base]
            targets = [t for t in targets if t in MODULES] or [base]
        else:
            continue
        for target in targets:
            while target and target not in MODULES:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _within(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def _layer(name: str) -> int | None:
    for prefix in sorted(LAYERS, key=len, reverse=True):
        if _within(name, prefix):
            return LAYERS[prefix]
    return None


def _circles() -> list[list[str]]:
    """Return the strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in sorted(GRAPH[node]):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(GRAPH):
        if node not in index:
            visit(node)
    return components


def _broken_rule(name: str, target: str) -> str | None:
    """Return why `name` must not import `target`, or None where it may."""
    if _within(name, "voxel"):
        if not _within(target, "voxel"):
            return "voxel imports neither offset nor pipeline"
        if target == COMPILED:
            return None
        if _within(name, "voxel.io") and not (
            _within(target, "voxel.io") or target in ("voxel.grid", "voxel.colour._srgb")
        ):
            return "voxel.io imports only voxel.grid and the sRGB helpers"
        if _within(name, "voxel.geometry") and not (
            _within(target, "voxel.geometry") or target == "voxel.grid"
        ):
            return "voxel.geometry imports only voxel.grid"
        if name == "voxel.slab" and _within(target, "voxel.io"):
            return "voxel.slab never imports voxel.io"
        return None
    if _within(name, "offset"):
        if _within(target, "pipeline"):
            return "offset never imports pipeline"
        if _within(target, "voxel") and target not in ("voxel.geometry._nearest", COMPILED):
            return "offset imports only voxel.geometry._nearest (and the kernels' decorator)"
        return None
    if not _within(target, "pipeline"):
        return None
    reader = next((r for r in READERS if _within(name, r)), None)
    target_reader = next((r for r in READERS if _within(target, r)), None)
    if target_reader is not None and target_reader != reader:
        if not (_within(name, "pipeline.cli") or (reader, target_reader) == READERS):
            return f"only cli (and report, of the viewer) imports {target_reader}"
        return None
    if reader is not None:
        if target_reader is None and _layer(target) not in (0, 3):
            return f"{reader} reads the output only (bottom and pipeline.output)"
        return None
    mine, theirs = _layer(name), _layer(target)
    if mine is None or theirs is None:
        return f"{name if mine is None else target} is in no layer"
    if theirs > mine:
        return "pipeline depends downward"
    if theirs == mine == 2 and name.split(".")[1] != target.split(".")[1]:
        return "loading, thickness and printer do not import each other"
    return None


def _violations() -> list[str]:
    return sorted(
        f"{name} -> {target}: {why}"
        for name, targets in GRAPH.items()
        for target in targets
        if (why := _broken_rule(name, target)) is not None
    )


def test_the_walk_sees_the_modules() -> None:
    assert len(MODULES) > 100
    assert "pipeline.run._task" in GRAPH["pipeline.run._runner"]
    assert "voxel.geometry._nearest" in GRAPH["offset.guards"]


def test_no_import_circles() -> None:
    assert _circles() == []


def test_imports_follow_the_rules() -> None:
    assert _violations() == []


def test_the_rules_catch_a_broken_import() -> None:
    assert _broken_rule("pipeline.run._runner", "pipeline.build._plan") is not None
    assert _broken_rule("voxel.slab", "voxel.io._tiff_pages") is not None
    assert _broken_rule("voxel.geometry._nearest", "pipeline.errors") is not None
    assert _broken_rule("offset.robust", "voxel.grid") is not None
    assert _broken_rule("pipeline.config", "pipeline.printer._material_plan") is not None
    assert _broken_rule("pipeline.viewer._depth", "pipeline.build._stack") is not None
    assert _broken_rule("pipeline.build._stack", "pipeline.report._previews") is not None
    assert _broken_rule("pipeline.cli.inspect", "pipeline.report._previews") is None


@pytest.mark.parametrize("package", sorted(MAX_TOP_MODULES))
def test_few_modules_at_the_top(package: str) -> None:
    top = sorted(p.name for p in (ROOT / package).glob("*.py"))
    assert len(top) <= MAX_TOP_MODULES[package], top


def test_every_stage_is_a_subpackage() -> None:
    for stage in STAGES:
        assert (ROOT / "pipeline" / stage / "__init__.py").is_file(), stage
    for part in ("geometry", "colour", "io"):
        assert (ROOT / "voxel" / part / "__init__.py").is_file(), part


def test_no_test_folder_shadows_a_package() -> None:
    # tests/ is on sys.path (pytest's pythonpath): a folder tests/voxel would be found as a
    # namespace package ``voxel`` where the editable install's finder comes later.
    # And pytest never collects a folder named build or dist (its default norecursedirs).
    folders = {p.name for p in (ROOT / "tests").iterdir() if p.is_dir()}
    assert folders.isdisjoint({*PACKAGES, "build", "dist"})


def test_no_module_is_a_monster() -> None:
    long = {
        name: n
        for name, path in MODULES.items()
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}
