"""Fit every material's K and S to a measured chart; write the profile with those optics."""

from __future__ import annotations

import argparse
from pathlib import Path


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
    import numpy as np

    from shellvox.api import calibrate

    fit = calibrate(args.chart, args.measured, args.output, folds=args.folds)
    residual, patches = fit.residual, fit.chart.patches
    rms = np.sqrt((residual**2).mean(axis=1))
    worst = np.abs(residual).max(axis=1)
    fit_de, checked = fit.fit_delta_e, fit.cross_validated
    print(
        f"fitted K and S of {len(fit.optics.names)} materials at "
        f"{len(fit.optics.wavelengths_nm)} bands to {len(patches)} patches"
    )
    print(
        f"residual reflectance: RMS {np.sqrt((residual**2).mean()):.4f}, per patch RMS median "
        f"{np.median(rms):.4f} max {rms.max():.4f}, largest {worst.max():.4f} "
        f"({patches[int(np.argmax(worst))].patch_id})"
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
    width = max(len(p.patch_id) for p in patches)
    for patch, r, w, e in zip(patches, rms, worst, fit_de, strict=True):
        print(f"  {patch.patch_id:<{width}}  {r:.4f}  {w:.4f}  {e:5.2f}")
    print(fit.profile)
    return 0
