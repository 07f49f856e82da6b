"""An open build folder for viewing: its manifest, grid, stacks and surface.

Opening checks that the folder is a complete build: a valid ``manifest.json``, and
every file it lists present, inside the folder (after symbolic links) and of the size
the build recorded (``shellvox inspect`` also compares checksums, which reads every
byte: too slow to wait for before a 5 G-voxel build opens). The stacks are then opened:
from the OME-Zarr store when the build has one
(:class:`~shellvox.viewer._zarr_stacks.ZarrStack`), else the TIFF stacks, indexed and kept
open (:class:`~shellvox.viewer._stacks.TiffStack`). Every failure is one
:class:`~shellvox.errors.InputError` line.

Only the files named here can ever be read: the stacks, ``thickness.ply``, ``proof.ply``
(the soft proof, read by the pass over the pages:
:class:`~shellvox.viewer._surface.Overview`) and ``manifest.json``, each by its resolved
path, fixed at opening.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from shellvox.errors import InputError
from shellvox.output import check_files, read_manifest
from shellvox.viewer._depth import Surface
from shellvox.viewer._stacks import StackError, StripCache, TiffStack
from shellvox.viewer._zarr_stacks import ZarrStack, read_context
from shellvox.voxel.grid import GridSpec

#: The stacks the viewer reads: name -> (file, samples). materials.tif is optional.
STACKS = {
    "layers": ("layers.tif", 0),
    "colour": ("colour.tif", 3),
    "materials": ("materials.tif", 0),
}

#: The OME-Zarr store's images: name -> (group in the store, colour).
ZARR_IMAGES = {
    "layers": ("labels/layers", False),
    "colour": (".", True),
    "materials": ("labels/materials", False),
}
ZARR_STORE = "stack.ome.zarr"

#: Where the stacks are read: the store when the build has one ("auto"), or as named.
Source = Literal["auto", "tiff", "zarr"]

#: Files the viewer hands out as they are (``/files/NAME``), when the build has them.
SERVED_FILES = ("manifest.json", "thickness.ply", "proof.ply")


@dataclass(frozen=True)
class Layer:
    """One layer of the build: ``index`` (0 outside .. K + 1 core), name, colour or not."""

    index: int
    name: str
    colour: bool
    depth_mm: float | None


@dataclass(frozen=True)
class Material:
    """One printer material: index in ``materials.tif``, name, role, display sRGB."""

    index: int
    name: str
    role: str
    display_srgb: tuple[int, int, int]


class BuildFolder:
    """A complete build, open for reading (see :meth:`open`)."""

    def __init__(
        self,
        root: Path,
        manifest: dict[str, Any],
        grid: GridSpec,
        stacks: dict[str, TiffStack | ZarrStack],
        surface: Surface | None,
        files: dict[str, Path],
    ) -> None:
        self.root = root
        self.manifest = manifest
        self.grid = grid
        self.stacks = stacks
        self.surface = surface
        self.files = files
        self._stop = threading.Event()
        self._warming: threading.Thread | None = None
        self.layers = tuple(
            Layer(
                int(layer["index"]),
                str(layer["name"]),
                bool(layer["colour"]),
                float(layer["depth_mm"]) if "depth_mm" in layer else None,
            )
            for layer in manifest["layers"]
        )
        self.materials = tuple(
            Material(
                int(m["index"]),
                str(m["name"]),
                str(m.get("role", "")),
                (int(m["display_srgb"][0]), int(m["display_srgb"][1]), int(m["display_srgb"][2])),
            )
            for m in manifest.get("materials") or []
        )

    @classmethod
    def open(cls, folder: Path, *, source: Source = "auto") -> BuildFolder:
        """Open the build in ``folder``; raise InputError when it is not a complete build.

        `source`: read the stacks from the OME-Zarr store (``"zarr"``; ``"auto"`` when the
        build has one) or the TIFF stacks (``"tiff"``).
        """
        folder = Path(folder)
        fix = f"give the output folder of a finished shellvox build, or build into {folder}"
        if not folder.is_dir():
            raise InputError(
                folder, "is not a folder", "give the output folder of a shellvox build"
            )
        manifest = read_manifest(folder)
        check_files(folder, manifest)
        try:
            grid_record = manifest["grid"]
            grid = GridSpec(
                tuple(float(v) for v in grid_record["origin_mm"]),  # type: ignore[arg-type]
                tuple(float(v) for v in grid_record["voxel_size_mm"]),  # type: ignore[arg-type]
                tuple(int(v) for v in grid_record["shape_zyx"]),  # type: ignore[arg-type]
            )
            layers_ok = all(
                isinstance(layer, dict) and {"index", "name", "colour"} <= set(layer)
                for layer in manifest["layers"]
            )
            if not layers_ok or len(manifest["layers"]) < 2:
                raise ValueError("its layers are not a list of {index, name, colour}")
            materials_ok = all(
                isinstance(m, dict) and {"index", "name", "display_srgb"} <= set(m)
                for m in manifest.get("materials") or []
            )
            if not materials_ok:
                raise ValueError("its materials are not a list of {index, name, display_srgb}")
        except (KeyError, TypeError, ValueError) as error:
            raise InputError(
                folder / "manifest.json", f"is not a valid build manifest ({error})", fix
            ) from None
        listed = manifest["files"]
        files = {"manifest.json": (folder / "manifest.json").resolve()}
        files.update({name: (folder / name).resolve() for name in SERVED_FILES if name in listed})
        stacks: dict[str, TiffStack | ZarrStack] = {}
        try:
            if source == "zarr" or (source == "auto" and f"{ZARR_STORE}/zarr.json" in listed):
                stacks.update(_zarr_stacks(folder, manifest, grid))
            else:
                stacks.update(_tiff_stacks(folder, manifest, grid))
        except StackError as error:
            for stack in stacks.values():
                stack.close()
            raise InputError(folder, f"a stack cannot be read: {error}", fix) from None
        surface = None
        if "thickness.ply" in files:
            try:
                surface = Surface.load(files["thickness.ply"])
            except (OSError, ValueError) as error:
                for stack in stacks.values():
                    stack.close()
                raise InputError(files["thickness.ply"], f"cannot be read ({error})", fix) from None
        return cls(folder.resolve(), manifest, grid, stacks, surface, files)

    def close(self) -> None:
        """Stop warming the cache, close the stacks."""
        self._stop.set()
        if self._warming is not None:
            self._warming.join()
        for stack in self.stacks.values():
            stack.close()

    def warm_in_background(self, screen_pixels: int = 1000) -> None:
        """Decode, in a thread, the pages a whole-model y or x slice shows.

        A zoomed-out view of a tall model reads every ``step``-th page (``step`` a power
        of two, about the model's pages per ``screen_pixels``); decoding them ahead
        makes the first y and x slices as quick as the next ones.
        """
        n_z = self.grid.shape_zyx[0]
        step = 2 ** max(0, round(math.log2(max(1.0, n_z / screen_pixels))))
        order = [s for s in ("layers", "colour", "materials") if s in self.stacks]

        def run() -> None:
            for name in order:
                self.stacks[name].warm(range(0, n_z, step), self._stop)

        self._warming = threading.Thread(target=run, name="warm-cache", daemon=True)
        self._warming.start()

    def __enter__(self) -> BuildFolder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _range(self, key: str, *, colour_only: bool) -> list[float]:
        """``[0, largest]`` of a per-face statistic of the bands (or colour layers), mm."""
        largest = 0.0
        for layer in self.manifest["layers"]:
            stats = layer.get(key)
            if isinstance(stats, dict) and (layer.get("colour") or not colour_only):
                largest = max(largest, float(stats.get("max", 0.0)))
            elif layer.get("depth_mm") is not None and (layer.get("colour") or not colour_only):
                largest = max(largest, float(layer["depth_mm"]))
        return [0.0, largest if largest > 0 else 1.0]

    def describe(self) -> dict[str, Any]:
        """Return what the page needs to know about the build (JSON-ready)."""
        return {
            "folder": str(self.root),
            "input": self.manifest.get("input", {}).get("path"),
            "grid": {
                "shape_zyx": list(self.grid.shape_zyx),
                "voxel_mm": list(self.grid.voxel_mm),
                "origin_mm": list(self.grid.origin_mm),
            },
            "layers": [layer.__dict__ for layer in self.layers],
            "materials": [
                {**m.__dict__, "display_srgb": list(m.display_srgb)} for m in self.materials
            ],
            "stacks": sorted(self.stacks),
            "colour_samples": self.stacks["colour"].samples,
            "depth": self.surface is not None,
            "proof": self.surface is not None and "proof.ply" in self.files,
            "depth_range_mm": self._range("depth_per_face_mm", colour_only=False),
            "thickness_range_mm": self._range("thickness_per_face_mm", colour_only=True),
            "files": sorted(self.files),
        }


def _tiff_stacks(folder: Path, manifest: dict[str, Any], grid: GridSpec) -> dict[str, TiffStack]:
    """Open the build's TIFF stacks (one decoded-page budget for them all)."""
    stacks: dict[str, TiffStack] = {}
    cache = StripCache()
    try:
        for key, (name, samples) in STACKS.items():
            if name not in manifest["files"]:
                continue
            if key == "colour":
                samples = int(manifest.get("tiff", {}).get(name, {}).get("samples", 3))
            stacks[key] = TiffStack(
                (folder / name).resolve(), grid.shape_zyx, samples=samples, cache=cache
            )
    except StackError:
        for stack in stacks.values():
            stack.close()
        raise
    return stacks


def _zarr_stacks(folder: Path, manifest: dict[str, Any], grid: GridSpec) -> dict[str, ZarrStack]:
    """Open the images of the build's OME-Zarr store (one chunk cache for them all)."""
    listed = manifest["files"]
    if f"{ZARR_STORE}/zarr.json" not in listed:
        raise StackError(f"{folder}: the build has no {ZARR_STORE}")
    store = (folder / ZARR_STORE).resolve()
    context = read_context()
    samples = int(manifest.get("zarr", {}).get("samples", 3))
    stacks = {}
    for key, (group, colour) in ZARR_IMAGES.items():
        if f"{ZARR_STORE}/{group}/zarr.json".replace("/./", "/") not in listed:
            continue
        stacks[key] = ZarrStack(
            store / group, grid.shape_zyx, samples=samples if colour else 0, context=context
        )
    return stacks
