"""A build folder's manifest: read it, and check the files it lists (sizes, checksums).

``manifest.json`` is written last by ``shellvox build`` and lists every file with its
size and SHA-256 (:mod:`shellvox.output._outdir`). A folder without a valid manifest, or whose
listed files are missing, of another size or outside the folder, is not a complete
build; each check raises :class:`~shellvox.errors.InputError` naming the file.
"""

from __future__ import annotations

import json
import math
import stat
from pathlib import Path
from typing import Any

from shellvox.errors import InputError
from shellvox.output._outdir import sha256

#: The stacks every build writes, as TIFFs or in the OME-Zarr store: a manifest must list
#: (and so verify) one or the other.
STACK_FILES = ("layers.tif", "colour.tif")
ZARR_ROOT = "stack.ome.zarr/zarr.json"


def read_manifest(folder: Path) -> dict[str, Any]:
    """Return the build's manifest, or raise InputError when it is missing or malformed."""
    path = folder / "manifest.json"
    fix = "rebuild with shellvox build -o " + str(folder)
    if not path.is_file():
        raise InputError(folder, "has no manifest.json (not a finished build)", fix)
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise InputError(path, f"is not valid JSON ({error})", fix) from None
    required = {"grid": dict, "layers": list, "files": dict, "seconds": dict, "input": dict}
    if not isinstance(manifest, dict) or not all(
        isinstance(manifest.get(key), kind) for key, kind in required.items()
    ):
        raise InputError(
            path,
            "is not a shellvox build manifest (or one written before files were listed)",
            fix,
        )
    grid = manifest["grid"]
    valid = {
        "shape_zyx": _numbers(grid.get("shape_zyx"), integer=True, low=1),
        "voxel_size_mm": _numbers(grid.get("voxel_size_mm"), low=1e-300),
        "origin_mm": _numbers(grid.get("origin_mm")),
    }
    problems = [f"grid {key} is {grid.get(key)!r}" for key, ok in valid.items() if not ok]
    missing = [name for name in STACK_FILES if name not in manifest["files"]]
    if missing and ZARR_ROOT not in manifest["files"]:
        problems.append(f"it does not list {' and '.join(missing)}")
    if problems:
        raise InputError(path, f"is not a valid build manifest: {'; '.join(problems)}", fix)
    return manifest


def _numbers(value: Any, *, integer: bool = False, low: float = -math.inf) -> bool:
    """Return whether `value` is a list of 3 finite numbers (integers) >= `low`."""
    kinds = (int,) if integer else (int, float)
    return (
        isinstance(value, list)
        and len(value) == 3
        and all(
            isinstance(v, kinds) and not isinstance(v, bool) and low <= v < math.inf for v in value
        )
    )


def check_files(folder: Path, manifest: dict[str, Any]) -> None:
    """Check that every file the manifest lists is there: inside, regular, of its size.

    The quick half of :func:`verify_files` (no checksums): a ``stat`` per file.
    """
    fix = "rebuild with shellvox build -o " + str(folder)
    root = folder.resolve()
    for name, record in manifest["files"].items():
        path = (folder / name).resolve()
        if root not in path.parents:
            raise InputError(folder / "manifest.json", f"lists {name!r} outside the folder", fix)
        try:
            info = path.stat()
        except OSError:
            raise InputError(folder / name, "is missing (the manifest lists it)", fix) from None
        if not stat.S_ISREG(info.st_mode):
            raise InputError(folder / name, "is not a regular file", fix)
        expected = record.get("bytes") if isinstance(record, dict) else None
        if info.st_size != expected:
            raise InputError(
                folder / name,
                f"has {info.st_size:,} bytes but the build wrote {expected} (truncated or changed)",
                fix,
            )


def verify_files(folder: Path, manifest: dict[str, Any]) -> None:
    """Check that every file the manifest lists is there, whole and unchanged (SHA-256)."""
    check_files(folder, manifest)
    fix = "rebuild with shellvox build -o " + str(folder)
    for name, record in manifest["files"].items():
        if sha256((folder / name).resolve()) != record.get("sha256"):
            raise InputError(
                folder / name, "differs from what the build wrote (SHA-256 mismatch)", fix
            )


def file_summary(files: dict[str, Any]) -> list[tuple[str, int, int]]:
    """Return ``(name, files, bytes)`` per listed file, a Zarr store's files as one row.

    A store (``NAME.zarr/...``) is named by its folder (``NAME.zarr/``), after the files.

    Examples
    --------
    >>> file_summary(
    ...     {"a.tif": {"bytes": 3}, "s.zarr/zarr.json": {"bytes": 2}, "s.zarr/0/c/0": {"bytes": 5}}
    ... )
    [('a.tif', 1, 3), ('s.zarr/', 2, 7)]
    """
    rows: list[tuple[str, int, int]] = []
    stores: dict[str, list[int]] = {}
    for name, record in files.items():
        top, _, rest = name.partition("/")
        if top.endswith(".zarr") and rest:
            stores.setdefault(top + "/", []).append(int(record["bytes"]))
        else:
            rows.append((name, 1, int(record["bytes"])))
    return rows + [(name, len(sizes), sum(sizes)) for name, sizes in stores.items()]


def manifest_line(manifest: dict[str, Any]) -> str:
    """Return a build in one short line: its grid, voxel size, printer and files.

    The ``repr`` of the objects that hold a manifest (a build's result, the opened build,
    its inspection). A folder of files (``slices/``, ``stack.ome.zarr/``) is one name.

    Parameters
    ----------
    manifest : dict
        A build's ``manifest.json``.

    Returns
    -------
    str
        ``shape_zyx=(Z, Y, X), voxel_mm=(vx, vy, vz), printer='NAME', files=(...)``; a
        value the manifest lacks is ``None``.

    Examples
    --------
    >>> grid = {"shape_zyx": [3, 7, 10], "voxel_size_mm": [0.5, 0.5, 0.1]}
    >>> files = {"a.tif": {}, "slices/0.png": {}, "slices/1.png": {}}
    >>> print(manifest_line({"grid": grid, "printer": "j750", "files": files}))
    shape_zyx=(3, 7, 10), voxel_mm=(0.5, 0.5, 0.1), printer='j750', files=('a.tif', 'slices/')
    """
    grid = manifest.get("grid") or {}
    shape = grid.get("shape_zyx")
    voxel = grid.get("voxel_size_mm")
    printer = manifest.get("printer")
    if isinstance(printer, dict):
        printer = printer.get("name")
    names = []
    for name in manifest.get("files") or {}:
        top, slash, _ = name.partition("/")
        names.append(top + slash)
    return (
        f"shape_zyx={None if shape is None else tuple(int(n) for n in shape)}, "
        f"voxel_mm={None if voxel is None else tuple(float(f'{v:.4g}') for v in voxel)}, "
        f"printer={printer!r}, files={tuple(dict.fromkeys(names))}"
    )
