"""Verify a build against its manifest, summarise it and draw previews.

Every file the manifest lists must be there, a regular file, of the recorded size and
SHA-256; otherwise one line names the file and the fix (rebuild). Previews
(:mod:`pipeline.report._previews`) in DIR/preview/: sections through the coloured surface with a
voxel-scale inset, the outer colour layer from six sides, the layer-depth histogram and
the halftone.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pipeline.errors import InputError
from pipeline.output import OutputFolder, file_summary, read_manifest, verify_files
from pipeline.report import write_previews


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inspect``'s arguments."""
    parser.add_argument("folder", type=Path, metavar="DIR", help="output folder of shellvox build")
    parser.add_argument("--no-preview", action="store_true", help="only print the summary")


def run(args: argparse.Namespace) -> int:
    """Verify the build against its manifest, print the summary, write DIR/preview/*.png."""
    folder: Path = args.folder
    if not folder.is_dir():
        raise InputError(folder, "is not a folder", "give the -o DIR of a shellvox build")
    if args.no_preview:  # reads only: no lock, so a build on a read-only medium verifies
        _verify_and_print(folder)
        return 0
    with OutputFolder(folder, outputs=("preview/*.png",), marker=".no-marker") as lock:
        manifest = _verify_and_print(folder)
        if "layers.tif" not in manifest["files"]:
            print("no previews: the previews are drawn from the TIFF stacks (--format tiff)")
            lock.commit([])
            return 0
        try:
            written = write_previews(folder, manifest)
        except (ValueError, OSError, KeyError, IndexError) as error:
            if isinstance(error, OSError) and not isinstance(error, FileNotFoundError):
                raise
            raise InputError(
                folder, f"the stack cannot be read ({error})", "rebuild with shellvox build"
            ) from None
        lock.commit(written)
        for path in written:
            print(f"{path}")
    return 0


def _verify_and_print(folder: Path) -> dict[str, Any]:
    manifest = read_manifest(folder)
    verify_files(folder, manifest)
    try:
        rows = summary_rows(manifest, folder)
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise InputError(
            folder / "manifest.json",
            f"has a malformed entry ({type(error).__name__}: {error})",
            "rebuild with shellvox build -o " + str(folder),
        ) from None
    for row in rows:
        print(f"{row[0]:<24} {row[1]}")
    return manifest


def summary_rows(manifest: dict[str, Any], folder: Path) -> list[tuple[str, str]]:
    """Return ``(label, value)`` rows describing a build."""
    grid = manifest["grid"]
    vx, vy, vz = grid["voxel_size_mm"]
    voxel_mm3 = vx * vy * vz
    rows = [
        ("input", f"{manifest['input']['path']} ({manifest['input']['faces']:,} faces)"),
        ("tool", manifest["tool"]),
        ("grid (z, y, x)", " x ".join(f"{n:,}" for n in grid["shape_zyx"])),
        ("voxel (x, y, z)", f"{vx:.4f} x {vy:.4f} x {vz:.4f} mm"),
        ("origin (x, y, z)", ", ".join(f"{v:.3f}" for v in grid["origin_mm"]) + " mm"),
    ]
    for layer in manifest["layers"]:
        volume = layer["voxels"] * voxel_mm3
        rows.append(
            (
                f"layer {layer['index']} {layer['name']}",
                f"{layer['voxels']:,} voxels, {volume:,.1f} mm^3",
            )
        )
    for name, n_files, n_bytes in file_summary(manifest["files"]):
        files = f"{n_files:,} files, " if name.endswith("/") else ""
        rows.append((name, f"{files}{n_bytes:,} bytes, verified"))
    for name, value in manifest["seconds"].items():
        rows.append((f"seconds {name}", f"{value:.2f}"))
    return rows
