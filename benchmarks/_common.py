"""What every benchmark shares: where the test meshes are, and how a result is written.

The meshes are found through one setting, the environment variable ``SHELLVOX_MESHES``
(default: ``../shared/meshes`` beside the checkout). Each benchmark writes one result,
``benchmarks/results/NAME.json`` (:func:`write_result`), read by the documentation's
performance page; a ``--quick`` run writes to ``out/bench-quick/`` instead, so a smoke
run never replaces a measured result.

    python benchmarks/_common.py meshes   # print the meshes folder (layout_identity.sh)
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import trimesh

ROOT = Path(__file__).resolve().parents[1]
MESHES = Path(os.environ.get("SHELLVOX_MESHES", ROOT.parent / "shared" / "meshes"))
RESULTS = Path(__file__).resolve().parent / "results"
QUICK_RESULTS = ROOT / "out" / "bench-quick"

#: The default model (shipped with the package).
DEFAULT_MODEL = ROOT / "data" / "colour_target" / "colour_target.obj"

#: The shared test meshes by short name, relative to MESHES.
SHARED = {
    "spot": "spot/spot_triangulated.obj",
    "duck": "duck/Duck.glb",
    "airplane": "airplane/colored_airplane.ply",
    "bunny": "bunny/bunny.obj",
    "box_textured": "box-textured/BoxTextured.glb",
    "cube_vertexcolor": "cube-vertexcolor/cube_with_vertexcolors.obj",
    "rhombicuboctahedron_3mf": "3mf/rhombicuboctahedron_color.3mf",
    "pyramid_3mf": "3mf/pyramid_vertexcolor.3mf",
    "box_3mf": "3mf/box.3mf",
}

#: The models of the colour benchmarks: name -> (mesh name, largest side mm or None).
COLOUR_MODELS = {
    "default": ("default", None),
    "spot_30mm": ("spot", 30.0),
    "duck_30mm": ("duck", 30.0),
    "airplane_30mm": ("airplane", 30.0),
}


def mesh_path(name: str) -> Path:
    """Return the file of a shared mesh (``"default"``: the default model).

    Exits with a line naming ``SHELLVOX_MESHES`` when the file is not there.
    """
    if name == "default":
        return DEFAULT_MODEL
    path = MESHES / SHARED[name]
    if not path.is_file():
        raise SystemExit(
            f"{path} is missing: the benchmarks read the shared test meshes from "
            "$SHELLVOX_MESHES (default ../shared/meshes beside the checkout)"
        )
    return path


def largest_extent(path: Path) -> float:
    """Return the largest side (file units) of the model at `path`, as shellvox loads it."""
    from shellvox import load_model

    vertices = load_model(path).vertices
    return float((vertices.max(axis=0) - vertices.min(axis=0)).max())


def scale_for(name: str, size_mm: float | None) -> float:
    """Return the ``--scale`` that makes mesh `name`'s largest side `size_mm` (None: 1)."""
    return 1.0 if size_mm is None else size_mm / largest_extent(mesh_path(name))


def scaled_mesh(name: str, size_mm: float | None = None, stretch_z: float = 1.0) -> Any:
    """Load mesh `name` with its largest side `size_mm` (as ``--scale``), z stretched."""
    from shellvox import load_model

    mesh = load_model(mesh_path(name))
    vertices = mesh.vertices.copy()
    if size_mm is not None:
        vertices *= size_mm / float((vertices.max(axis=0) - vertices.min(axis=0)).max())
    vertices[:, 2] *= stretch_z
    return dataclasses.replace(mesh, vertices=vertices)


def load_shared(name: str, size_mm: float, subdivisions: int = 0) -> trimesh.Trimesh:
    """Load a shared mesh merged by position, Loop-subdivided, largest extent `size_mm`."""
    import trimesh

    raw = trimesh.load(mesh_path(name), force="mesh")
    mesh = trimesh.Trimesh(raw.vertices, raw.faces, process=True)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    if subdivisions > 0:
        mesh = mesh.subdivide_loop(iterations=subdivisions)
    mesh.apply_scale(size_mm / mesh.extents.max())
    assert mesh.is_watertight and mesh.is_winding_consistent
    return mesh


def parser(doc: str | None) -> argparse.ArgumentParser:
    """Return an argument parser described by `doc`, with ``--quick``."""
    parsed = argparse.ArgumentParser(
        description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parsed.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run on tiny inputs, written to out/bench-quick/ (not results/)",
    )
    return parsed


def machine() -> str:
    """Return this machine in one line: cores, memory, CPU model, system, Python."""
    cores = len(os.sched_getaffinity(0))
    memory_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 1e9
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return (
        f"{cores} cores, {memory_gb:.1f} GB memory, {cpu}, {platform.system()} "
        f"{platform.release()} {platform.machine()}, Python {platform.python_version()}"
    )


def rerun_command() -> str:
    """Return the command that reran this benchmark, from the repository root."""
    script = Path(sys.argv[0]).name
    return " ".join(["python", f"benchmarks/{script}", *map(shlex.quote, sys.argv[1:])])


def load_average() -> list[float]:
    """Return the 1, 5 and 15 minute load averages (the machine may be shared)."""
    return [round(v, 2) for v in os.getloadavg()]


def previous_details(name: str, *, quick: bool = False) -> dict[str, Any]:
    """Return the ``details`` of the current result of `name` (empty if none), to merge.

    Its ``run`` (the date, commit and load of the earlier run) and ``sources`` (where a
    converted result's parts came from) are left out: they no longer describe the whole.
    """
    path = (QUICK_RESULTS if quick else RESULTS) / f"{name}.json"
    if not path.is_file():
        return {}
    details = json.loads(path.read_text()).get("details")
    if not isinstance(details, dict):
        return {}
    return {key: value for key, value in details.items() if key not in ("run", "sources")}


def write_result(name: str, result: dict[str, Any], *, quick: bool = False) -> Path:
    """Write ``results/NAME.json`` (``--quick``: ``out/bench-quick/NAME.json``); return it.

    `result` holds ``what`` (one sentence: what is measured, against which peer),
    ``summary`` (one flat dict per case: numbers and short labels, the table of the
    performance page) and ``details`` (everything else); ``command`` (how to rerun it)
    and ``machine`` default to this run's. A summary row lacking a column of another
    row gets ``"-"`` there; ``None`` becomes ``"-"``, booleans ``"yes"`` or ``"no"``.
    """
    unknown = set(result) - {"what", "machine", "command", "summary", "details"}
    if unknown or not {"what", "summary", "details"} <= set(result):
        raise ValueError(f"{name}: a result holds what, summary and details, got {sorted(result)}")
    columns: dict[str, None] = {}
    for row in result["summary"]:
        columns.update(dict.fromkeys(row))
    summary = [{key: _cell(row.get(key)) for key in columns} for row in result["summary"]]
    details = dict(result["details"])
    details.setdefault("run", _run_facts())
    record = {
        "what": result["what"],
        "machine": result.get("machine") or machine(),
        "command": result.get("command") or rerun_command(),
        "summary": summary,
        "details": details,
    }
    folder = QUICK_RESULTS if quick else RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.json"
    text = json.dumps(portable(record), indent=1, allow_nan=False) + "\n"
    path.write_text(text, encoding="utf-8")
    return path


def _cell(value: Any) -> Any:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int | float | str):
        return value
    raise TypeError(f"a summary cell is a number or a short label, got {value!r}")


def _run_facts() -> dict[str, Any]:
    """The date, the code's commit (when a git checkout) and the load average."""
    facts: dict[str, Any] = {"date": time.strftime("%Y-%m-%d %H:%M")}
    with contextlib.suppress(OSError, subprocess.CalledProcessError):
        facts["commit"] = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    facts["load_average_1_5_15_min_at_end"] = load_average()
    return facts


def portable(value: Any) -> Any:
    """Return `value` with this checkout's and the meshes' absolute paths made relative.

    NaN and infinities become None (JSON has neither).
    """
    if isinstance(value, dict):
        return {key: portable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [portable(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        value = str(value)
    if isinstance(value, str):
        for folder, name in ((MESHES.resolve(), "$SHELLVOX_MESHES"), (ROOT, ".")):
            value = value.replace(str(folder) + "/", name + "/").replace(str(folder), name)
    return value


class TreeRss:
    """Sample the summed RSS of this process and all its descendants (Linux ``/proc``).

    Slab workers are separate processes, so ``ru_maxrss`` of one process alone would
    understate a build's memory. ``peak_kb`` holds the peak once the block has ended.
    """

    def __init__(self, interval_s: float = 0.05) -> None:
        self.peak_kb = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(interval_s,), daemon=True)

    def __enter__(self) -> TreeRss:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self, interval_s: float) -> None:
        while not self._stop.wait(interval_s):
            self.peak_kb = max(self.peak_kb, sum(_rss_kb(pid) for pid in _tree(os.getpid())))


def _tree(pid: int) -> list[int]:
    found = [pid]
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        with contextlib.suppress(OSError):
            for child in task.read_text().split():
                found += _tree(int(child))
    return found


def _rss_kb(pid: int) -> int:
    with contextlib.suppress(OSError):
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


if __name__ == "__main__":
    if sys.argv[1:] == ["meshes"]:
        print(MESHES)
    else:
        raise SystemExit("usage: python benchmarks/_common.py meshes")
