"""A build's output folder checked without shellvox: its manifest, hashes, leftovers.

Every file is hashed with :mod:`hashlib` and the TIFF stacks are read with tifffile; the
temporary files are recognised by name (:data:`TEMPORARY_HINTS`), not by shellvox's code.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

#: Names shellvox gives its temporary files; no shellvox output starts with a dot.
TEMPORARY_HINTS = (".partial", ".vdb-spool", ".staging", ".shellvox.lock")


def temporary_files(folder: Path) -> list[Path]:
    """Return what a run left in `folder` (recursively) that is not a shellvox output."""
    if not folder.exists():
        return []
    return sorted(
        path
        for path in folder.rglob("*")
        if path.name.startswith(".") or any(hint in path.name for hint in TEMPORARY_HINTS)
    )


def holds_nothing(folder: Path, extra: tuple[str, ...] = ()) -> bool:
    """Return whether `folder` is absent or holds only `extra` (no build, no temporary)."""
    if not folder.exists():
        return True
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} == set(extra)


def verified_files(folder: Path, extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """Check a finished build against its manifest, independently of shellvox; return it.

    Every file in `folder` (but `extra`, files of the user's) is ``manifest.json`` or listed
    in it, every listed file is there with the recorded size and SHA-256 (recomputed here
    with hashlib), and the TIFF stacks read back with tifffile at the grid's shape.

    Raises
    ------
    AssertionError
        A check failed.
    """
    import tifffile

    manifest: dict[str, Any] = json.loads((folder / "manifest.json").read_text())
    present = {str(p.relative_to(folder)) for p in folder.rglob("*") if not p.is_dir()}
    assert present == {"manifest.json", *manifest["files"], *extra}, present
    for name, record in manifest["files"].items():
        data = (folder / name).read_bytes()
        assert len(data) == record["bytes"], name
        assert hashlib.sha256(data).hexdigest() == record["sha256"], name
    n_z, n_y, n_x = manifest["grid"]["shape_zyx"]
    for name in ("layers.tif", "colour.tif"):
        with tifffile.TiffFile(folder / name) as tif:
            assert len(tif.pages) == n_z
            assert tif.pages[0].shape[:2] == (n_y, n_x)
    return manifest
