"""The layout of the package: import rules, no import circles, sizes.

The imports are read with :mod:`ast` from every module of ``shellvox`` (the folders
``pipeline/``, ``offset/`` and ``voxel/``: all modules, those under ``if TYPE_CHECKING``
and inside functions too), so a rule broken by a lazy import counts.

``shellvox.voxel`` (voxels: grids, kernels, colour, writers) and ``shellvox.offset``
(shell offsetting) are the bottom: neither imports the stages (but offset imports
``errors``, which imports nothing of the package, for :func:`shellvox.errors.warn`).
Inside ``shellvox.offset``, bottom up: its base (``_validate``, ``adjacency``,
``shells``), ``crossing``, then ``field``, ``quality`` and ``reference`` side by side,
then ``methods`` (the registry) and the package itself. The stages (the folder
``pipeline/``), bottom up (a module imports only its own layer and those below):

0. bottom: ``shellvox`` (the version and the lazy public names), ``errors``, ``config``,
   ``faults``, ``atomic``, ``kernel_cache``
1. ``model`` (the coloured mesh, textures, topology)
2. ``loading``, ``thickness``, ``printer`` (side by side: none imports another)
3. ``output`` (the folder, the streams, the manifest and its checks, shells, PLY) and, beside
   it, ``fdm`` (the 3MF projects for FDM slicers, from the model, thickness and shells)
4. ``run`` (slab tasks and where they run)
5. ``stack`` (one model's build)
6. ``tray`` (several models, one job)
7. ``api`` (what each command does, as functions)
8. ``cli``
9. ``testing`` (checks of what shellvox writes, by tools that are not shellvox's, for the
   tests and the benchmarks: no part of the package imports it)

``report``, ``viewer`` and ``reading`` read an output folder: they import the bottom and
``output`` (``report`` also the viewer's stack pages); only ``api`` and ``cli`` import them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The folders and the names they have in the package.
FOLDERS = {"pipeline": "shellvox", "offset": "shellvox.offset", "voxel": "shellvox.voxel"}
VOXEL, OFFSET = "shellvox.voxel", "shellvox.offset"

LAYERS = {
    "shellvox": 0, "shellvox.errors": 0, "shellvox.config": 0, "shellvox.faults": 0,
    "shellvox.atomic": 0, "shellvox.kernel_cache": 0, "shellvox.model": 1,
    "shellvox.loading": 2, "shellvox.thickness": 2,
    "shellvox.printer": 2, "shellvox.output": 3, "shellvox.fdm": 3, "shellvox.run": 4,
    "shellvox.stack": 5, "shellvox.tray": 6, "shellvox.api": 7, "shellvox.cli": 8,
    "shellvox.testing": 9,
}  # fmt: skip
READERS = ("shellvox.report", "shellvox.viewer", "shellvox.reading")
STAGES = ("model", "loading", "thickness", "printer", "output", "fdm", "run", "stack", "tray",
          "report", "viewer", "cli")  # fmt: skip
MAX_TOP_MODULES = {"pipeline": 8, "voxel": 10, "offset": 10}
MAX_LINES = 1000  # a sanity limit: modules are split by concept, not by a count
#: The one decorator of compiled kernels: every part of the package may import it.
COMPILED = "shellvox.voxel._compiled"
#: The error and warning types and ``warn`` (no import of the package): offset may import it.
ERRORS = "shellvox.errors"


def _modules() -> dict[str, Path]:
    found = {}
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = path.relative_to(ROOT / folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((package, *parts))] = path
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


def _stage(name: str) -> bool:
    """Whether `name` is a module of the stages (not of shellvox.voxel or shellvox.offset)."""
    return not (_within(name, VOXEL) or _within(name, OFFSET))


#: The order inside shellvox.offset, bottom up: its base modules, the crossing tests, the
#: methods' parts side by side (none imports another), then the registry and the package.
OFFSET_ORDER = {"base": 0, "crossing": 1, "field": 2, "quality": 2, "reference": 2, "top": 3}


def _offset_part(name: str) -> str:
    """Return the part of shellvox.offset that module `name` belongs to (OFFSET_ORDER)."""
    rest = name[len(OFFSET) :].lstrip(".").split(".")[0]
    if rest in OFFSET_ORDER:
        return rest
    return "top" if rest in ("", "methods") else "base"


def _broken_rule(name: str, target: str) -> str | None:
    """Return why `name` must not import `target`, or None where it may."""
    if _within(name, VOXEL):
        if not _within(target, VOXEL):
            return "shellvox.voxel imports neither offset nor the stages"
        if target == COMPILED:
            return None
        if _within(name, f"{VOXEL}.io") and not (
            _within(target, f"{VOXEL}.io") or target in (f"{VOXEL}.grid", f"{VOXEL}.colour._srgb")
        ):
            return "shellvox.voxel.io imports only voxel.grid and the sRGB helpers"
        if _within(name, f"{VOXEL}.geometry") and not (
            _within(target, f"{VOXEL}.geometry") or target == f"{VOXEL}.grid"
        ):
            return "shellvox.voxel.geometry imports only voxel.grid"
        if name == f"{VOXEL}.slab" and _within(target, f"{VOXEL}.io"):
            return "shellvox.voxel.slab never imports voxel.io"
        return None
    if _within(name, OFFSET):
        if _stage(target) and target != ERRORS:
            return "shellvox.offset never imports the stages"
        if _within(target, OFFSET):
            mine, theirs = _offset_part(name), _offset_part(target)
            if OFFSET_ORDER[theirs] > OFFSET_ORDER[mine] or (
                OFFSET_ORDER[theirs] == OFFSET_ORDER[mine] == 2 and mine != theirs
            ):
                return "offset: base < crossing < field, quality, reference (apart) < methods"
            return None
        if not _within(target, VOXEL) or target in (f"{VOXEL}.geometry._nearest", COMPILED):
            return None
        field_scan = _within(target, f"{VOXEL}.geometry") or target == f"{VOXEL}.grid"
        if _within(name, f"{OFFSET}.field") and field_scan:
            return None  # the field method scans the layer field with the voxels' kernels
        return "offset imports only voxel.geometry._nearest (the field method: the scan)"
    if not _stage(target):
        return None
    reader = next((r for r in READERS if _within(name, r)), None)
    target_reader = next((r for r in READERS if _within(target, r)), None)
    if target_reader is not None and target_reader != reader:
        allowed = _within(name, "shellvox.cli") or _within(name, "shellvox.api")
        if not (allowed or (reader, target_reader) == READERS[:2]):
            return f"only api and cli (and report, of the viewer) import {target_reader}"
        return None
    if reader is not None:
        if target_reader is None and _layer(target) not in (0, 3):
            return f"{reader} reads the output only (bottom and shellvox.output)"
        return None
    mine, theirs = _layer(name), _layer(target)
    if mine is None or theirs is None:
        return f"{name if mine is None else target} is in no layer"
    if theirs > mine:
        return "the stages depend downward"
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
    assert "shellvox.run._task" in GRAPH["shellvox.run._runner"]
    assert "shellvox.voxel.geometry._nearest" in GRAPH["shellvox.offset.reference.guards"]


def test_no_import_circles() -> None:
    assert _circles() == []


def test_imports_follow_the_rules() -> None:
    assert _violations() == []


def test_the_rules_catch_a_broken_import() -> None:
    assert _broken_rule("shellvox.run._runner", "shellvox.stack._plan") is not None
    assert _broken_rule("shellvox.voxel.slab", "shellvox.voxel.io._tiff_pages") is not None
    assert _broken_rule("shellvox.voxel.geometry._nearest", "shellvox.errors") is not None
    assert _broken_rule("shellvox.offset.reference.robust", "shellvox.voxel.grid") is not None
    assert _broken_rule("shellvox.offset.field.layer_field", "shellvox.voxel.grid") is None
    assert _broken_rule("shellvox.offset.field.layer_field", "shellvox.voxel.slab") is not None
    assert _broken_rule("shellvox.offset.field.simplify", "shellvox.offset.reference.jitter")
    assert _broken_rule("shellvox.offset.crossing.intersections", "shellvox.offset.quality")
    assert _broken_rule("shellvox.offset.shells", "shellvox.offset.methods") is not None
    assert _broken_rule("shellvox.offset.methods", "shellvox.offset.field.simplify") is None
    assert _broken_rule("shellvox.config", "shellvox.printer._material_plan") is not None
    assert _broken_rule("shellvox.viewer._depth", "shellvox.stack._stack") is not None
    assert _broken_rule("shellvox.stack._stack", "shellvox.report._previews") is not None
    assert _broken_rule("shellvox.cli.inspect", "shellvox.report._previews") is None
    assert _broken_rule("shellvox.cli", "shellvox.testing") is not None
    assert _broken_rule("shellvox.voxel.io.vdb", "shellvox.testing._openvdb") is not None
    assert _broken_rule("shellvox.testing._shell_files", "shellvox.offset.crossing") is None


@pytest.mark.parametrize("package", sorted(MAX_TOP_MODULES))
def test_few_modules_at_the_top(package: str) -> None:
    top = sorted(p.name for p in (ROOT / package).glob("*.py"))
    assert len(top) <= MAX_TOP_MODULES[package], top


def test_every_stage_is_a_subpackage() -> None:
    for stage in STAGES:
        assert (ROOT / "pipeline" / stage / "__init__.py").is_file(), stage
    for part in ("geometry", "colour", "io"):
        assert (ROOT / "voxel" / part / "__init__.py").is_file(), part
    for part in ("field", "crossing", "quality", "reference"):
        assert (ROOT / "offset" / part / "__init__.py").is_file(), part


def test_no_test_folder_shadows_the_package() -> None:
    # tests/ is on sys.path (pytest's pythonpath): a folder tests/shellvox would be found as
    # a namespace package ``shellvox`` where the editable install's finder comes later.
    # And pytest never collects a folder named build or dist (its default norecursedirs).
    folders = {p.name for p in (ROOT / "tests").iterdir() if p.is_dir()}
    assert folders.isdisjoint({"shellvox", "build", "dist"})


def test_no_module_is_a_monster() -> None:
    long = {
        name: n
        for name, path in MODULES.items()
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert long == {}
