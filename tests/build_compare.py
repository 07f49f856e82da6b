"""Compare two build folders file by file, as read back (helpers for the run tests)."""

from __future__ import annotations

import hashlib
import json
import uuid
from pathlib import Path
from typing import Any


def output_digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every file the manifest lists (volume.vdb's UUID is derived from its
    content, so equal builds have equal files byte for byte)."""
    manifest = json.loads((folder / "manifest.json").read_text())
    digests = {}
    for name in manifest["files"]:
        data = (folder / name).read_bytes()
        if name.endswith(".vdb"):
            uuid.UUID(data[21:57].decode("ascii"))  # the file's UUID is where OpenVDB reads it
        digests[name] = hashlib.sha256(data).hexdigest()
    return digests


def manifest_core(folder: Path) -> dict[str, Any]:
    """The manifest without what may differ between equal builds: timings, how it ran
    and the estimate (which depends on the workers)."""
    manifest = json.loads((folder / "manifest.json").read_text())
    for key in ("seconds", "run", "estimate"):
        manifest.pop(key)
    manifest["config"].pop("workers")
    return manifest


def differences(left: Any, right: Any, path: str = "") -> list[str]:
    """Paths (``a.b[2]``) at which two JSON values differ, with both values."""
    if isinstance(left, dict) and isinstance(right, dict):
        found = []
        for key in sorted(set(left) | set(right), key=str):
            if key not in left or key not in right:
                found.append(f"{path}.{key}: only on one side")
            else:
                found += differences(left[key], right[key], f"{path}.{key}")
        return found
    if isinstance(left, list) and isinstance(right, list) and len(left) == len(right):
        return [
            d
            for i, (a, b) in enumerate(zip(left, right, strict=True))
            for d in differences(a, b, f"{path}[{i}]")
        ]
    return [] if left == right else [f"{path}: {left!r} != {right!r}"]
