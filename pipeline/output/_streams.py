"""The build's streaming writers: every output file, fed one slab at a time.

``layers.tif``, ``colour.tif`` and ``materials.tif`` (ImageJ stacks), ``volume.vdb``
(density, layer, color, sdf and material grids), ``job.gcvf`` (GrabCAD Voxel Print),
``slices/`` (RGBA colour-and-translucency PNGs) and ``stack.ome.zarr/`` (OME-Zarr: colour,
materials and layers), as ``BuildConfig.formats`` chooses. Each file is written under a
temporary name of the build's folder (:meth:`shellvox.output._folder.BuildFolder.temporary`)
and appears only when the whole build succeeded; the writers only serialise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox import __version__
from shellvox.config import BuildConfig
from shellvox.errors import InputError, opt
from shellvox.output._folder import BuildFolder
from shellvox.printer import PrinterProfile
from shellvox.voxel.colour import MaterialPlan
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import (
    BAND_RGB,
    CORE_RGB,
    RGBA,
    GcvfJobError,
    GcvfWriter,
    KeySlices,
    LabelValue,
    OmeZarrWriter,
    PngSliceWriter,
    ShardEncoder,
    TiffStackWriter,
    encoded_by_slabs,
    key_rgba,
    material_table,
)
from shellvox.voxel.io.vdb import GridSpool, VdbStackWriter
from shellvox.voxel.slab import SlabResult


class StackOutputs:
    """Open the chosen writers in the build's folder; :meth:`write` feeds them a slab.

    Parameters
    ----------
    folder : BuildFolder
        The output folder: its stack owns the writers and the temporary files (closed or
        removed with it).
    grid : GridSpec
        The voxel grid.
    config : BuildConfig
        Which files, compression, colour layers.
    profile : PrinterProfile or None
        Materials (names, keys, display colours); None: no material outputs.
    plan : MaterialPlan or None
        Which material indices the voxels may hold (with `profile`).
    surface : ((V, 3) float64 mm, (F, 3) int64), optional
        The surface built (the model, or the tray's models placed), for the printer job's
        ``Mesh.stl``.
    """

    #: The OME-Zarr store's folder name.
    ZARR_NAME = "stack.ome.zarr"

    def __init__(
        self,
        folder: BuildFolder,
        grid: GridSpec,
        config: BuildConfig,
        profile: PrinterProfile | None,
        plan: MaterialPlan | None,
        surface: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None,
    ) -> None:
        self.folder = folder
        self.grid = grid
        stack = folder.stack
        self.samples = 4 if config.alpha else 3
        self._is_colour = np.zeros(256, dtype=bool)
        self._is_colour[list(config.colour_layers)] = True
        formats = set(config.formats)
        with_materials = profile is not None and plan is not None
        level = config.compression_level
        self.layers_tif = self.colour_tif = self.materials_tif = None
        if "tiff" in formats:
            self.layers_tif = self._tiff("layers.tif", 0, level)
            self.colour_tif = self._tiff("colour.tif", self.samples, level)
            if with_materials:
                self.materials_tif = self._tiff("materials.tif", 0, level)
        self.vdb: VdbStackWriter | None = None
        self._vdb_path = None
        if "vdb" in formats:
            self.vdb = VdbStackWriter(
                grid,
                sdf_half_width_mm=config.sdf_half_width_mm,
                spool_dir=folder.path,
                material_grid=with_materials,
            )
            stack.callback(self.vdb.close)  # the leaf spools go, whatever happens
            self._vdb_path = folder.temporary("volume.vdb")
        self.gcvf: GcvfWriter | None = None
        self.png: PngSliceWriter | None = None
        self._display = np.zeros((256, 4), dtype=np.uint8)
        if with_materials:
            assert profile is not None and plan is not None
            for material in profile.materials[1:]:
                self._display[material.index] = (*material.display_srgb, 255)
            if "gcvf" in formats:
                self.gcvf = self._gcvf(profile, plan, surface)
            if "png" in formats:
                self.png = stack.enter_context(
                    PngSliceWriter(
                        folder.path / "slices",
                        grid,
                        metadata={"creator": f"shellvox {__version__}", "printer": profile.name},
                    )
                )
        self.zarr: OmeZarrWriter | None = None
        if "zarr" in formats:
            labels = zarr_labels(config, profile if with_materials else None)
            self.zarr = stack.enter_context(
                OmeZarrWriter(
                    folder.path / self.ZARR_NAME,
                    grid,
                    samples=self.samples,
                    labels=labels,
                )
            )

    def _tiff(self, name: str, samples: int, level: int | None) -> TiffStackWriter:
        path = self.folder.temporary(name)
        return self.folder.stack.enter_context(
            TiffStackWriter(path, self.grid, samples=samples, compression_level=level)
        )

    def _gcvf(
        self,
        profile: PrinterProfile,
        plan: MaterialPlan,
        surface: tuple[NDArray[np.float64], NDArray[np.int64]] | None,
    ) -> GcvfWriter:
        table = _gcvf_table(profile, plan)
        path = self.folder.temporary("job.gcvf")
        writer = gcvf_writer(path, self.grid, table, profile, surface)
        return self.folder.stack.enter_context(writer)

    def write(
        self,
        slab: SlabResult,
        materials: NDArray[np.uint8] | None,
        vdb: list[GridSpool] | None = None,
        pages: dict[str, list[bytes]] | None = None,
        counts: NDArray[np.int64] | None = None,
    ) -> None:
        """Write one slab (in z order) to every open writer.

        `vdb`: the slab's VDB leaves already encoded
        (:class:`shellvox.voxel.io.vdb._encode.VdbEncoder`); `pages`: its TIFF pages and job slices
        already encoded, by file name (:class:`shellvox.voxel.io._tiff_pages.PageEncoder`, made with
        this build's levels and :func:`gcvf_slices`); `counts`: its voxels per layer and material
        ``(L, 256)``, which the job's slices need with them.
        """
        pages = pages or {}
        stacks = (
            ("layers.tif", self.layers_tif, slab.layers),
            ("colour.tif", self.colour_tif, slab.rgba[..., : self.samples]),
            ("materials.tif", self.materials_tif, materials),
        )
        for name, writer, array in stacks:
            if writer is None or array is None:
                continue
            if name in pages:
                writer.write_pages(pages[name])
            else:
                writer.write_slab(array)
        if self.vdb is not None and vdb is not None:
            self.vdb.write_encoded(slab.z_start, slab.z_stop - slab.z_start, vdb)
        elif self.vdb is not None:
            coloured = self._is_colour[slab.layers]
            self.vdb.write_slab(
                slab.z_start, slab.layers, slab.rgba[..., :3], coloured, slab.sdf, materials
            )
        if self.gcvf is not None and "job.gcvf" in pages and counts is not None:
            assert materials is not None  # a job's slices are made with the materials
            self.gcvf.write_encoded(pages["job.gcvf"], counts.sum(axis=0), materials)
        elif self.gcvf is not None and materials is not None:
            self.gcvf.write_slab(materials)
        if self.png is not None and materials is not None:
            self.png.write_slab(self.colour_slices(slab, materials))
        if self.zarr is not None:
            labels = {"layers": slab.layers}
            if materials is not None and "materials" in self.zarr.label_names:
                labels["materials"] = materials
            shards = pages.get(self.ZARR_NAME)
            self.zarr.write_slab(slab.rgba, self._is_colour[slab.layers], labels, shards)

    def colour_slices(self, slab: SlabResult, materials: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Return the RGBA ``(Zs, Y, X, 4) uint8`` of a slab for colour-slice printers.

        Colour layers carry the surface colour and its alpha, other solid voxels their
        material's display colour, void is transparent black.
        """
        rgba = self._display[materials]
        coloured = self._is_colour[slab.layers]
        rgba[coloured] = slab.rgba[coloured]
        return rgba

    def finish(self) -> dict[str, Any]:
        """Close every writer (files still under temporary names); return their summaries."""
        summary: dict[str, Any] = {}
        tiffs = {
            "layers.tif": self.layers_tif,
            "colour.tif": self.colour_tif,
            "materials.tif": self.materials_tif,
        }
        for name, writer in tiffs.items():
            if writer is not None:
                writer.close()
                summary.setdefault("tiff", {})[name] = {
                    "bigtiff": writer.bigtiff,
                    "samples": max(1, writer.samples),
                }
        if self.vdb is not None and self._vdb_path is not None:
            summary["vdb"] = self.vdb.write(self._vdb_path, {"creator": f"shellvox {__version__}"})
        if self.gcvf is not None:
            job = self.gcvf.close()
            summary["gcvf"] = {
                "slices": job.n_slices,
                "padding_slices": job.n_padding_slices,
                "slice_width": job.slice_width,
                "slice_height": job.slice_height,
                "materials": [
                    {"index": m.index, "job_name": m.name, "rgba_key": list(m.rgba), "voxels": n}
                    for m, n in job.materials
                ],
                "files": list(job.files),
            }
        if self.png is not None:
            self.png.close()
            slices = self.folder.path / "slices"
            self.folder.add(sorted(p for p in slices.iterdir() if p.is_file()))
            summary["png_slices"] = {"folder": "slices", "files": len(list(slices.iterdir()))}
        if self.zarr is not None:
            files = self.zarr.close()
            self.folder.add(files)
            summary["zarr"] = {
                "folder": self.ZARR_NAME,
                "ngff": "0.5",
                "files": len(files),
                "levels": 1 + len(self.zarr.factors),
                "level_factors_zyx": [list(f) for f in self.zarr.factors],
                "labels": list(self.zarr.label_names),
                "samples": self.samples,
            }
        return summary


def zarr_labels(config: BuildConfig, profile: PrinterProfile | None) -> dict[str, list[LabelValue]]:
    """Return the store's label images and their values: materials (with `profile`), layers."""
    labels = {"layers": _layer_labels(config)}
    if profile is not None:
        labels = {"materials": _material_labels(profile), **labels}
    return labels


def zarr_shards(
    grid: GridSpec, config: BuildConfig, slab_rows: int, profile: PrinterProfile | None
) -> ShardEncoder | None:
    """Return the slab workers' encoder of the store's level-0 shards.

    None where there is no store or slabs of `slab_rows` do not hold whole shards (the
    store's writer then makes them). The same arrays as :class:`StackOutputs` makes (with
    `profile` when the voxels have materials).
    """
    if "zarr" not in config.formats or not encoded_by_slabs(slab_rows):
        return None
    labels = tuple(zarr_labels(config, profile))
    return ShardEncoder(grid.shape_zyx, 4 if config.alpha else 3, slab_rows, labels)


def _material_labels(profile: PrinterProfile) -> list[LabelValue]:
    """Return every material (not void) of `profile` as a label value: display colour, name."""
    return [
        LabelValue(m.index, (*m.display_srgb, 255), {"name": m.name, "role": m.role})
        for m in profile.materials[1:]
    ]


def _layer_labels(config: BuildConfig) -> list[LabelValue]:
    """Return the layers (outside, bands, core) as label values, named as in the manifest."""
    n_bands = len(config.thickness_mm)
    values = [LabelValue(0, (255, 255, 255, 0), {"name": "outside", "colour": False})]
    for k in range(1, n_bands + 1):
        colour = k in config.colour_layers
        rgb = BAND_RGB[(k - 1) % len(BAND_RGB)]
        name = f"{'colour' if colour else 'backing'}_{k}"
        values.append(LabelValue(k, (*rgb, 255), {"name": name, "colour": colour}))
    values.append(LabelValue(n_bands + 1, (*CORE_RGB, 255), {"name": "core", "colour": False}))
    return values


def _gcvf_table(profile: PrinterProfile, plan: MaterialPlan) -> list[tuple[int, str, RGBA]]:
    """Return the job's material table: ``(index, job_name, rgba_key)`` of every usable one."""
    used = sorted({*plan.column_materials, plan.backing_material, plan.core_material})
    materials = profile.materials
    return [(index, materials[index].job_name, materials[index].rgba_key) for index in used]


def gcvf_slices(profile: PrinterProfile, plan: MaterialPlan) -> KeySlices | None:
    """Return the slice encoder of the build's job (as :class:`StackOutputs` makes it).

    None when the table breaks a job limit: the writer refuses the job then.
    """
    try:
        background = key_rgba(profile.materials[0].rgba_key, "background_rgba")
        table = material_table(_gcvf_table(profile, plan), background, profile.max_materials)
    except GcvfJobError:
        return None
    return KeySlices.of(table, background, "max_y", None)


def gcvf_writer(
    path: Path,
    grid: GridSpec,
    table: list[tuple[int, str, RGBA]],
    profile: PrinterProfile,
    surface: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None,
) -> GcvfWriter:
    """Return the ``.gcvf`` job writer of `profile` for `grid` at `path` (`surface`: its mesh).

    Raises
    ------
    InputError
        The profile's grid, materials or limits make no job (names ``--printer``).
    """
    try:
        return GcvfWriter(
            path,
            grid,
            table,
            background_rgba=profile.materials[0].rgba_key,
            dpi=(int(profile.dpi[0]), int(profile.dpi[1])),
            slice_thickness_nm=profile.slice_thickness_nm,
            max_materials=profile.max_materials,
            min_slices=profile.min_slices,
            tray_mm=profile.tray_mm,
            surface=surface,
        )
    except GcvfJobError as error:
        raise InputError(
            opt("printer", profile.name),
            f"cannot make a .gcvf job: {error.problem}",
            error.fix,
        ) from None
