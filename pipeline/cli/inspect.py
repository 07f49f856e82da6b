"""Summarise a built stack and draw previews (sections and a layer-depth histogram)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import tifffile

from pipeline.errors import InputError
from voxel.atomic import atomic_path
from voxel.preview import boundary_depths, histogram_image, section_image


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inspect``'s arguments."""
    parser.add_argument("folder", type=Path, metavar="DIR", help="output folder of shellvox build")
    parser.add_argument("--no-preview", action="store_true", help="only print the summary")


def run(args: argparse.Namespace) -> int:
    """Print the summary table; write DIR/preview/*.png."""
    folder: Path = args.folder
    manifest_path = folder / "manifest.json"
    if not manifest_path.is_file():
        raise InputError(
            folder, "has no manifest.json (not a finished build)", "run shellvox build"
        )
    manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
    for row in summary_rows(manifest, folder):
        print(f"{row[0]:<24} {row[1]}")
    if not args.no_preview:
        for path in write_previews(folder, manifest):
            print(f"{path}")
    return 0


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
    for path in sorted(folder.rglob("*")):
        if path.is_file() and not path.name.startswith("."):
            rows.append((str(path.relative_to(folder)), f"{path.stat().st_size:,} bytes"))
    for name, value in manifest["seconds"].items():
        rows.append((f"seconds {name}", f"{value:.2f}"))
    return rows


def write_previews(folder: Path, manifest: dict[str, Any]) -> list[Path]:
    """Write mid-height XY, XZ and YZ sections and the depth histogram to DIR/preview/."""
    n_z, n_y, n_x = manifest["grid"]["shape_zyx"]
    vx, vy, vz = manifest["grid"]["voxel_size_mm"]
    n_bands = len(manifest["layers"]) - 2
    colour_layers = tuple(layer["index"] for layer in manifest["layers"] if layer["colour"])
    xz_layers = np.zeros((n_z, n_x), np.uint8)
    yz_layers = np.zeros((n_z, n_y), np.uint8)
    xz_rgb = np.zeros((n_z, n_x, 3), np.uint8)
    yz_rgb = np.zeros((n_z, n_y, 3), np.uint8)
    with (
        tifffile.TiffFile(folder / "layers.tif") as lt,
        tifffile.TiffFile(folder / "colour.tif") as ct,
    ):
        for z in range(n_z):  # one page at a time: memory stays one page
            page = lt.pages[z].asarray()
            colour = ct.pages[z].asarray()[..., :3]
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
    return written


def _thickness(layer: dict[str, Any]) -> float:
    thickness: float = layer["thickness_mm"]
    return thickness
