"""Fit every material's K and S to a measured chart; write the profile with those optics."""

from __future__ import annotations

import argparse
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from pipeline.atomic import write_text_atomic
from pipeline.errors import InputError
from pipeline.printer import chart_readings, parse_profile, profile_with_optics, read_chart
from voxel.colour import cross_validate, delta_e_of_readings, fit_optics


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``calibrate``'s arguments."""
    parser.add_argument("chart", type=Path, help="DIR/chart.json written by shellvox chart")
    parser.add_argument(
        "measured",
        type=Path,
        help="the chart's spectral readings, CGATS.17 (i1Profiler SPECTRAL_NM400 ..., "
        "ArgyllCMS SPEC_400 ...; percent or fraction; d/8, specular included)",
    )
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        metavar="PROFILE.toml",
        help="the printer profile to write, with [optics] and each material's K and S",
    )
    parser.add_argument(
        "--folds", type=int, default=5, help="cross-validation folds (held-out patches)"
    )


def run(args: argparse.Namespace) -> int:
    """Read, match, fit, cross-validate, print the residuals and write the profile."""
    out: Path = args.output
    if not out.parent.is_dir():
        raise InputError(out, "its folder does not exist", "create it or choose another path")
    if out.is_dir():
        raise InputError(out, "is a folder", "give the path of a .toml file")
    if args.folds < 2:
        raise InputError(f"--folds {args.folds}", "must be at least 2", "use e.g. 5")
    chart = read_chart(args.chart)
    measured = chart_readings(chart, args.measured)
    if args.folds > len(chart.patches):
        raise InputError(f"--folds {args.folds}", "exceeds the patches", "use fewer folds")
    fitted, residual = fit_optics(chart.optics, chart.patches, measured)
    checked = cross_validate(chart.optics, chart.patches, measured, folds=args.folds)
    header = (
        f"Printer profile {chart.printer_name!r} with optics fitted by shellvox calibrate\n"
        f"from {args.chart} and {args.measured} on {datetime.now(UTC):%Y-%m-%d %H:%M} UTC\n"
        f"(cross-validated CIEDE2000 median {checked['median']:.2f}, p95 {checked['p95']:.2f}).\n"
        "Comments of the original profile are not kept."
    )
    text = profile_with_optics(chart.printer_toml, fitted, header=header)
    profile = parse_profile(text, source=str(out))  # what load_profile will read
    assert not profile.optics.assumed
    rms = np.sqrt((residual**2).mean(axis=1))
    worst = np.abs(residual).max(axis=1)
    fit_de = delta_e_of_readings(fitted, measured + residual, measured)
    print(
        f"fitted K and S of {len(fitted.names)} materials at {len(fitted.wavelengths_nm)} bands "
        f"to {len(chart.patches)} patches"
    )
    print(
        f"residual reflectance: RMS {np.sqrt((residual**2).mean()):.4f}, per patch RMS median "
        f"{np.median(rms):.4f} max {rms.max():.4f}, largest {worst.max():.4f} "
        f"({chart.patches[int(np.argmax(worst))].patch_id})"
    )
    print(
        f"fit CIEDE2000: median {np.median(fit_de):.2f}, p95 {np.percentile(fit_de, 95):.2f}, "
        f"max {fit_de.max():.2f}"
    )
    print(
        f"cross-validated CIEDE2000 ({checked['folds']} folds, held-out patches): median "
        f"{checked['median']:.2f}, p95 {checked['p95']:.2f}, max {checked['max']:.2f}"
    )
    print("per patch: residual RMS, largest |residual| (reflectance), CIEDE2000 of the fit")
    width = max(len(p.patch_id) for p in chart.patches)
    for patch, r, w, e in zip(chart.patches, rms, worst, fit_de, strict=True):
        print(f"  {patch.patch_id:<{width}}  {r:.4f}  {w:.4f}  {e:5.2f}")
    write_text_atomic(out, text)
    print(out)
    return 0
