"""Verify a build against its manifest, summarise it and draw previews.

Every file the manifest lists must be there, a regular file, of the recorded size and
SHA-256; otherwise one line names the file and the fix (rebuild). Previews are sections
and a layer-depth histogram in DIR/preview/.
"""

from __future__ import annotations

import argparse
import json
import math
import stat
from pathlib import Path
from typing import Any

import numpy as np
import tifffile

from pipeline.atomic import atomic_path
from pipeline.errors import InputError
from pipeline.outdir import OutputFolder, sha256
from voxel.preview import boundary_depths, halftone_image, histogram_image, section_image

#: The files inspect reads: a manifest must list (and so verify) them.
STACK_FILES = ("layers.tif", "colour.tif")


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
    if missing:
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


def verify_files(folder: Path, manifest: dict[str, Any]) -> None:
    """Check that every file the manifest lists is there, whole and unchanged (SHA-256)."""
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
        if sha256(path) != record.get("sha256"):
            raise InputError(
                folder / name, "differs from what the build wrote (SHA-256 mismatch)", fix
            )


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
    for name, record in manifest["files"].items():
        rows.append((name, f"{record['bytes']:,} bytes, verified"))
    for name, value in manifest["seconds"].items():
        rows.append((f"seconds {name}", f"{value:.2f}"))
    return rows


def write_previews(folder: Path, manifest: dict[str, Any]) -> list[Path]:
    """Write mid-height XY, XZ and YZ sections and the depth histogram to DIR/preview/."""
    n_z, n_y, n_x = manifest["grid"]["shape_zyx"]
    vx, vy, vz = manifest["grid"]["voxel_size_mm"]
    n_bands = len(manifest["layers"]) - 2
    colour_layers = tuple(layer["index"] for layer in manifest["layers"] if layer["colour"])
    with (
        tifffile.TiffFile(folder / "layers.tif") as lt,
        tifffile.TiffFile(folder / "colour.tif") as ct,
    ):
        for name, tif in (("layers.tif", lt), ("colour.tif", ct)):  # before allocating
            shape = (len(tif.pages), *tif.pages[0].shape[:2]) if len(tif.pages) else (0,)
            if shape != (n_z, n_y, n_x):
                raise ValueError(
                    f"{name} holds {shape} (z, y, x) voxels but the manifest's grid is "
                    f"{(n_z, n_y, n_x)}"
                )
        xz_layers = np.zeros((n_z, n_x), np.uint8)
        yz_layers = np.zeros((n_z, n_y), np.uint8)
        xz_rgb = np.zeros((n_z, n_x, 3), np.uint8)
        yz_rgb = np.zeros((n_z, n_y, 3), np.uint8)
        is_colour = np.zeros(256, dtype=bool)
        is_colour[list(colour_layers)] = True
        colour_voxels = np.zeros(n_z, dtype=np.int64)
        for z in range(n_z):  # one page at a time: memory stays one page
            page = lt.pages[z].asarray()
            colour = ct.pages[z].asarray()[..., :3]
            colour_voxels[z] = np.count_nonzero(is_colour[page])
            xz_layers[z], yz_layers[z] = page[n_y // 2], page[:, n_x // 2]
            xz_rgb[z], yz_rgb[z] = colour[n_y // 2], colour[:, n_x // 2]
            if z == n_z // 2:
                xy_layers, xy_rgb = page, colour
    sections = {
        "xy_mid.png": (xy_layers[::-1], xy_rgb[::-1], (vx, vy)),
        "xz_mid.png": (xz_layers[::-1], xz_rgb[::-1], (vx, vz)),
        "yz_mid.png": (yz_layers[::-1], yz_rgb[::-1], (vy, vz)),
    }
    preview = folder / "preview"
    preview.mkdir(exist_ok=True)
    written = []
    depths: list[list[np.ndarray[Any, Any]]] = [[] for _ in range(n_bands)]
    for name, (layers, rgb, pixel_mm) in sections.items():
        image = section_image(
            layers, rgb, colour_layers=colour_layers, n_bands=n_bands, pixel_mm=pixel_mm
        )
        with atomic_path(preview / name) as temporary:
            image.save(temporary, format="PNG")
        written.append(preview / name)
        for band, values in enumerate(boundary_depths(layers, pixel_mm, n_bands)):
            depths[band].append(values)
    expected = list(np.cumsum([float(_thickness(layer)) for layer in manifest["layers"][1:-1]]))
    image = histogram_image([np.concatenate(d) for d in depths], expected)
    with atomic_path(preview / "layer_depth_histogram.png") as temporary:
        image.save(temporary, format="PNG")
    written.append(preview / "layer_depth_histogram.png")
    if "materials.tif" in manifest["files"] and manifest.get("materials"):
        written.append(_halftone_preview(folder, manifest, int(np.argmax(colour_voxels))))
    return written


def _halftone_preview(folder: Path, manifest: dict[str, Any], z: int) -> Path:
    """Draw slice `z` (the one with the most colour-layer voxels): target vs halftone."""
    vx, vy, _ = manifest["grid"]["voxel_size_mm"]
    display = np.zeros((256, 3), dtype=np.uint8)
    for material in manifest["materials"]:
        display[int(material["index"])] = material["display_srgb"]
    with (
        tifffile.TiffFile(folder / "layers.tif") as lt,
        tifffile.TiffFile(folder / "colour.tif") as ct,
        tifffile.TiffFile(folder / "materials.tif") as mt,
    ):
        layers = lt.pages[z].asarray()
        colour = ct.pages[z].asarray()[..., :3]
        materials = mt.pages[z].asarray()
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    target = np.where(np.isin(layers, colour_layers)[..., None], colour, display[materials])
    image = halftone_image(
        target[::-1].astype(np.uint8), materials[::-1], display, pixel_mm=(vx, vy)
    )
    path = folder / "preview" / f"halftone_z{z:05d}.png"
    with atomic_path(path) as temporary:
        image.save(temporary, format="PNG")
    return path


def _thickness(layer: dict[str, Any]) -> float:
    thickness: float = layer["thickness_mm"]
    return thickness
