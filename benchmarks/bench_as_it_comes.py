"""The build of an open model (read as it comes, inside from the winding number) against
the same model closed, in the same run.

    python benchmarks/bench_as_it_comes.py [--quick] [--runs 3] [--models spot,bunny]

Pairs (``--models``, default spot): spot (5,856 faces, textured), the Stanford bunny
(3,674 faces, no colour) or another shared OBJ model, each whole (one closed, oriented
part: the exact row-crossing build) and with 1 % of its faces deleted at random (seed
0; the ``f`` lines of the OBJ dropped, every other line kept, so the file is read the
same way; its material and texture beside it): then the model is open, and
``build`` reads it as it comes (holes closed by the winding number, the solid's inside
from the winding number, only visible faces make layers and colour). The Utah teapot
(992 faces, open, 4 parts through each other) is timed as it comes, with no closed peer.

Each build is the public API's :func:`shellvox.build` with the defaults of
``shellvox build MODEL --size 30`` (J750 grid, the thickness rule, materials, every
default file); the time is the wall time of ``build`` from the file (the loading and,
for an open model, the solid included) and of its load alone
(:func:`shellvox.load_model` with ``check="solid"``, what ``build`` calls). Runs
alternate whole and open, median of ``--runs`` (3) each, after one untimed small build
of each (the compiled kernels loaded; not with ``--quick``). The open build's agreement
with the whole one: the share of voxels with the same layer (grids of the same shape),
and of voxels inside in both. ``--quick``: at 5 mm, one run each, no teapot, to
``out/bench-quick/``.
"""

from __future__ import annotations

import json
import shutil
import statistics
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from _common import MESHES, load_average, mesh_path, parser, write_result

NAME = "bench_as_it_comes"
WHAT = (
    "Build time of an open model read as it comes (inside from the winding number) against "
    "the same model closed, same run: spot at 30 mm on the J750 grid, whole and with 1 % "
    "of its faces deleted; the open teapot as it comes."
)
TEAPOT = MESHES / "teapot" / "teapot.obj"
#: Share of the faces deleted to open a closed model.
DELETED_SHARE = 0.01


def opened(source: Path, folder: Path, share: float, seed: int = 0) -> tuple[Path, int]:
    """Write `source` (OBJ) to `folder` with `share` of its ``f`` lines dropped at random.

    Every other line is kept, and the files beside `source` (material, texture) are
    copied beside it (a temporary folder), so the open model is read as the closed one
    is. Returns the copy and the number of faces deleted.
    """
    lines = source.read_text().splitlines(keepends=True)
    faces = np.flatnonzero([line.startswith("f ") for line in lines])
    drop = np.random.default_rng(seed).choice(
        faces, max(1, round(share * len(faces))), replace=False
    )
    keep = np.ones(len(lines), dtype=bool)
    keep[drop] = False
    for other in source.parent.iterdir():
        if other != source and other.is_file():
            shutil.copyfile(other, folder / other.name)
    target = folder / f"{source.stem}_open{source.suffix}"
    target.write_text("".join(line for line, kept in zip(lines, keep, strict=True) if kept))
    return target, len(drop)


def timed_build(path: Path, out: Path, size_mm: float) -> dict[str, Any]:
    """Load `path` and build it as ``shellvox build PATH --size SIZE`` does; times in s."""
    import shellvox

    load = shellvox.LoadOptions(size_mm=size_mm)
    start = time.perf_counter()
    with warnings.catch_warnings():  # the line of what was done: said once, by the build
        warnings.simplefilter("ignore", shellvox.ShellvoxWarning)
        shellvox.load_model(path, load, check="solid")
    load_s = time.perf_counter() - start
    start = time.perf_counter()
    result = shellvox.build(path, out, load=load, progress=False)
    build_s = time.perf_counter() - start
    loaded = result.manifest["input"]["loaded"]
    return {
        "build_s": round(build_s, 3),
        "load_s": round(load_s, 3),
        "voxels": int(np.prod(result.manifest["grid"]["shape_zyx"])),
        "as_it_comes": loaded.get("as_it_comes"),
    }


def agreement(whole: Path, open_: Path) -> dict[str, Any]:
    """Voxels with the same layer, and inside in both, in two builds' ``layers.tif``."""
    import tifffile

    a = tifffile.imread(whole / "layers.tif")
    b = tifffile.imread(open_ / "layers.tif")
    if a.shape != b.shape:
        return {"same_grid": False, "shapes": [list(a.shape), list(b.shape)]}
    inside = (a > 0) | (b > 0)
    return {
        "same_grid": True,
        "same_layer_share_of_voxels": float(np.mean(a == b)),
        "same_layer_share_inside": float(np.mean(a[inside] == b[inside])),
        "both_inside_share_inside": float(np.mean((a > 0)[inside] & (b > 0)[inside])),
    }


def pair(name: str, folder: Path, size_mm: float, runs: int, warm: bool) -> dict[str, Any]:
    """Time model `name` whole and with faces deleted, alternating; median of `runs`.

    `warm`: one untimed 5 mm build of each first.
    """
    whole = mesh_path(name)
    holes = folder / f"{name}_files"
    holes.mkdir()
    open_path, deleted = opened(whole, holes, DELETED_SHARE)
    for path in (whole, open_path) if warm else ():  # the compiled kernels loaded, untimed
        timed_build(path, folder / "warm", 5.0)
    times: dict[str, list[dict[str, Any]]] = {"whole": [], "open": []}
    for i in range(runs):
        order = ("whole", "open") if i % 2 == 0 else ("open", "whole")
        for kind in order:
            path = whole if kind == "whole" else open_path
            entry = timed_build(path, folder / f"{name}_{kind}", size_mm)
            times[kind].append(entry)
            print(f"{name} {kind} run {i + 1}: {entry}", flush=True)
    whole_s = statistics.median(e["build_s"] for e in times["whole"])
    open_s = statistics.median(e["build_s"] for e in times["open"])
    return {
        "faces": sum(1 for line in whole.read_text().splitlines() if line.startswith("f ")),
        "faces_deleted": deleted,
        "size_mm": size_mm,
        "voxels": times["whole"][0]["voxels"],
        "whole_build_s": whole_s,
        "open_build_s": open_s,
        "open_over_whole": round(open_s / whole_s, 3),
        "whole_load_s": statistics.median(e["load_s"] for e in times["whole"]),
        "open_load_s": statistics.median(e["load_s"] for e in times["open"]),
        "read_as_it_comes": times["open"][0]["as_it_comes"],
        "whole_read_as_it_comes": times["whole"][0]["as_it_comes"],
        "agreement": agreement(folder / f"{name}_whole", folder / f"{name}_open"),
        "runs": times,
    }


def teapot(folder: Path, size_mm: float, runs: int) -> dict[str, Any]:
    """Time the open teapot as it comes; median of `runs`."""
    if not TEAPOT.is_file():
        raise SystemExit(f"{TEAPOT} is missing: the benchmarks read $SHELLVOX_MESHES")
    timed_build(TEAPOT, folder / "warm", 5.0)
    times = [timed_build(TEAPOT, folder / "teapot", size_mm) for _ in range(runs)]
    return {
        "faces": sum(1 for line in TEAPOT.read_text().splitlines() if line.startswith("f ")),
        "size_mm": size_mm,
        "voxels": times[0]["voxels"],
        "open_build_s": statistics.median(e["build_s"] for e in times),
        "open_load_s": statistics.median(e["load_s"] for e in times),
        "read_as_it_comes": times[0]["as_it_comes"],
        "runs": times,
    }


def summary(details: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for case, entry in details["cases"].items():
        agree = entry.get("agreement", {})
        rows.append({
            "case": case,
            "faces": entry["faces"],
            "faces deleted": entry.get("faces_deleted"),
            "size mm": entry["size_mm"],
            "voxels": entry["voxels"],
            "whole build s": entry.get("whole_build_s"),
            "open build s": entry["open_build_s"],
            "open/whole": entry.get("open_over_whole"),
            "whole load s": entry.get("whole_load_s"),
            "open load s": entry["open_load_s"],
            "same layer % inside": (
                round(100 * agree["same_layer_share_inside"], 3) if agree.get("same_grid") else None
            ),
        })  # fmt: skip
    return rows


def main() -> None:
    parsed = parser(__doc__)
    parsed.add_argument("--runs", type=int, default=3, help="timed builds of each (median)")
    parsed.add_argument(
        "--models", default="spot", help="closed OBJ models opened (comma-separated)"
    )
    args = parsed.parse_args()
    runs = 1 if args.quick else args.runs
    size_mm = 5.0 if args.quick else 30.0
    details: dict[str, Any] = {
        "load_average_1_5_15_min_at_start": load_average(),
        "deleted_share": DELETED_SHARE,
        "cases": {},
    }
    with tempfile.TemporaryDirectory(prefix="bench_as_it_comes_") as tmp:
        folder = Path(tmp)
        for name in args.models.split(","):
            details["cases"][f"{name} whole vs 1 % deleted"] = pair(
                name, folder, size_mm, runs, warm=not args.quick
            )
        if not args.quick:
            details["cases"]["teapot as it comes"] = teapot(folder, size_mm, runs)
    details["load_average_1_5_15_min_at_end"] = load_average()
    print(json.dumps(summary(details), indent=1))
    path = write_result(
        NAME, {"what": WHAT, "summary": summary(details), "details": details}, quick=args.quick
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
