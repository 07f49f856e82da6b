"""The calibration chart and the fit of the optics to its measurement.

What ``shellvox chart`` and ``shellvox calibrate`` do: :func:`make_chart` writes a
printable chart of stacked material layers; once printed and measured, :func:`calibrate`
fits every material's Kubelka-Munk K and S to the readings and writes the printer profile
with those optics, which then replace the assumed ones.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.atomic import atomic_path, write_text_atomic
from shellvox.errors import InputError, opt
from shellvox.output import OutputFolder, gcvf_writer
from shellvox.printer import (
    ChartFile,
    ChartLayout,
    PrinterProfile,
    chart_json,
    chart_layout,
    chart_preview,
    chart_readings,
    chart_slab,
    load_profile,
    parse_profile,
    profile_text,
    profile_with_optics,
    read_chart,
)
from shellvox.voxel.colour import Optics, cross_validate, delta_e_of_readings, fit_optics
from shellvox.voxel.io import PngSliceWriter

#: What ``chart`` writes (``chart.json`` last: the folder's complete-run marker).
CHART_OUTPUTS = ("chart.json", "job.gcvf", "preview/chart.png", "slices/*")
#: Slices made and written at a time.
SLAB_SLICES = 16


@dataclass(frozen=True, eq=False)
class ChartResult:
    """What :func:`make_chart` wrote.

    Attributes
    ----------
    folder : Path
    files : tuple of Path
        The printer's job (``job.gcvf``, or ``slices/`` for a PNG printer), the preview
        ``preview/chart.png`` and ``chart.json`` (each patch's layers, for calibrate).
    layout : ChartLayout
        The patches, their places and the chart's grid.
    printer : str
        The printer profile's name.
    """

    folder: Path
    files: tuple[Path, ...]
    layout: ChartLayout
    printer: str

    def __repr__(self) -> str:
        """One line: the folder, the patches, the grid, the printer and the files."""
        return (
            f"ChartResult({str(self.folder)!r}, {len(self.layout.patches)} patches, "
            f"shape_zyx={self.layout.grid.shape_zyx}, printer={self.printer!r}, "
            f"files={tuple(p.name for p in self.files)})"
        )


def make_chart(out_dir: str | Path, *, printer: str | Path = "j750") -> ChartResult:
    """Write a printable calibration chart for `printer` into `out_dir`.

    Examples
    --------
    >>> import shellvox
    >>> chart = shellvox.make_chart("chart")
    >>> sorted(p.name for p in chart.files)
    ['chart.json', 'chart.png', 'job.gcvf']
    >>> len(chart.layout.patches)
    78
    """
    out = Path(out_dir)
    profile = load_profile(printer)
    try:
        layout = chart_layout(profile)
    except ValueError as error:
        raise InputError(
            opt("printer", str(printer)), str(error), "use a profile with both"
        ) from None
    content = chart_json(layout, profile, profile_text(printer))
    with OutputFolder(out, CHART_OUTPUTS, marker="chart.json") as folder:
        if profile.slice_format == "gcvf":
            files = [_write_job(out / "job.gcvf", layout, profile)]
        else:
            files = _write_slices(out / "slices", layout, profile)
        (out / "preview").mkdir(exist_ok=True)
        with atomic_path(out / "preview" / "chart.png") as temporary:
            chart_preview(layout, profile).save(temporary, format="PNG")
        files.append(out / "preview" / "chart.png")
        content["files"] = folder.commit(files)
        write_text_atomic(out / "chart.json", json.dumps(content, indent=1))
    return ChartResult(out, (*files, out / "chart.json"), layout, profile.name)


def _write_job(path: Path, layout: ChartLayout, profile: PrinterProfile) -> Path:
    table = [(m.index, m.job_name, m.rgba_key) for m in profile.materials[1:]]
    with atomic_path(path) as temporary:
        writer = gcvf_writer(temporary, layout.grid, table, profile)
        with writer:
            for z0 in range(0, layout.grid.shape_zyx[0], SLAB_SLICES):  # loop over slabs
                writer.write_slab(
                    chart_slab(layout, z0, min(z0 + SLAB_SLICES, layout.grid.shape_zyx[0]))
                )
    return path


def _write_slices(folder: Path, layout: ChartLayout, profile: PrinterProfile) -> list[Path]:
    from shellvox import __version__

    display = np.zeros((256, 4), np.uint8)
    for material in profile.materials[1:]:
        display[material.index] = (*material.display_srgb, 255)
    metadata = {"creator": f"shellvox {__version__}", "printer": profile.name, "chart": True}
    with PngSliceWriter(folder, layout.grid, metadata=metadata) as writer:
        for z0 in range(0, layout.grid.shape_zyx[0], SLAB_SLICES):  # loop over slabs
            writer.write_slab(
                display[chart_slab(layout, z0, min(z0 + SLAB_SLICES, layout.grid.shape_zyx[0]))]
            )
    return sorted(p for p in folder.iterdir() if p.is_file())


@dataclass(frozen=True, eq=False)
class Calibration:
    """The fit of the optics to a measured chart (:func:`calibrate`).

    Attributes
    ----------
    profile : Path
        The printer profile written, with ``[optics]`` and each material's K and S.
    chart : ChartFile
        The chart that was measured.
    optics : Optics
        The fitted optics.
    residual : (N, B) float64
        Measured minus predicted reflectance of each patch at each band.
    fit_delta_e : (N,) float64
        CIEDE2000 between each patch's prediction and its reading.
    cross_validated : dict
        ``folds``, ``median``, ``p95``, ``max``: CIEDE2000 of held-out patches.
    """

    profile: Path
    chart: ChartFile
    optics: Optics
    residual: NDArray[np.float64]
    fit_delta_e: NDArray[np.float64]
    cross_validated: dict[str, Any]

    def __repr__(self) -> str:
        """One line: the profile written, the materials and patches, the fit's CIEDE2000."""
        fit = float(np.median(self.fit_delta_e)) if len(self.fit_delta_e) else float("nan")
        return (
            f"Calibration({str(self.profile)!r}, {len(self.optics.names)} materials, "
            f"{len(self.chart.patches)} patches, fit CIEDE2000 median {fit:.2f}, "
            f"cross-validated median {self.cross_validated.get('median', float('nan')):.2f})"
        )


def calibrate(
    chart: str | Path, measured: str | Path, out_profile: str | Path, *, folds: int = 5
) -> Calibration:
    """Fit every material's K and S to a measured chart; write the profile with them.

    Parameters
    ----------
    chart : path
        ``chart.json`` written by :func:`make_chart`.
    measured : path
        The chart's spectral readings, CGATS.17 (i1Profiler ``SPECTRAL_NM400`` ...,
        ArgyllCMS ``SPEC_400`` ...; percent or fraction; d/8, specular included).
    out_profile : path
        The printer profile (``.toml``) to write.
    folds : int
        Cross-validation folds (held-out patches).

    Returns
    -------
    Calibration

    Examples
    --------
    A printer exactly as assumed, "measured" by the model itself:

    >>> import shellvox
    >>> from shellvox.printer import Readings, read_chart, write_cgats
    >>> from shellvox.voxel.colour import predict
    >>> chart = shellvox.make_chart("chart")
    >>> read = read_chart("chart/chart.json")
    >>> spectra = predict(read.optics, list(read.patches))
    >>> ids = tuple(patch.patch_id for patch in read.patches)
    >>> write_cgats("readings.txt", Readings(ids, read.optics.wavelengths_nm, spectra))
    >>> fit = shellvox.calibrate("chart/chart.json", "readings.txt", "mine.toml")
    >>> shellvox.load_profile("mine.toml").optics.assumed
    False
    """
    out = Path(out_profile)
    if not out.parent.is_dir():
        raise InputError(out, "its folder does not exist", "create it or choose another path")
    if out.is_dir():
        raise InputError(out, "is a folder", "give the path of a .toml file")
    if folds < 2:
        raise InputError(opt("folds", folds), "must be at least 2", "use e.g. 5")
    read = read_chart(chart)
    readings = chart_readings(read, measured)
    if folds > len(read.patches):
        raise InputError(opt("folds", folds), "exceeds the patches", "use fewer folds")
    fitted, residual = fit_optics(read.optics, read.patches, readings)
    checked = cross_validate(read.optics, read.patches, readings, folds=folds)
    header = (
        f"Printer profile {read.printer_name!r} with optics fitted by shellvox calibrate\n"
        f"from {chart} and {measured} on {datetime.now(UTC):%Y-%m-%d %H:%M} UTC\n"
        f"(cross-validated CIEDE2000 median {checked['median']:.2f}, p95 {checked['p95']:.2f}).\n"
        "Comments of the original profile are not kept."
    )
    text = profile_with_optics(read.printer_toml, fitted, header=header)
    profile = parse_profile(text, source=str(out))  # what load_profile will read
    assert not profile.optics.assumed
    fit_de = delta_e_of_readings(fitted, readings + residual, readings)
    write_text_atomic(out, text)
    return Calibration(out, read, fitted, residual, fit_de, checked)
