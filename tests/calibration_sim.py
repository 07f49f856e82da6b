"""A simulated print and measurement of the chart: hidden optics, noisy readings, CGATS."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from shellvox.voxel.colour import Optics, Patch, predict

NOISE = 0.002  # reflectance, one sigma


def hidden_truth(start: Optics, seed: int = 7, sigma: float = 0.3, knots: int = 6) -> Optics:
    """`start` with K and S times smooth lognormal factors (interpolated from `knots`)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, len(start.wavelengths_nm))
    at = np.linspace(0.0, 1.0, knots)

    def perturb(values: np.ndarray) -> np.ndarray:
        factors = rng.normal(0.0, sigma, (values.shape[0], knots))
        smooth = np.stack([np.interp(t, at, f) for f in factors])
        return values * np.exp(smooth)

    return replace(start, k_per_mm=perturb(start.k_per_mm), s_per_mm=perturb(start.s_per_mm))


def measure(truth: Optics, patches: list[Patch], seed: int = 11) -> np.ndarray:
    """Readings of `patches` under `truth` with N(0, NOISE) noise, kept within [0, 1]."""
    rng = np.random.default_rng(seed)
    readings = predict(truth, patches)
    return np.clip(readings + rng.normal(0.0, NOISE, readings.shape), 0.0, 1.0)


def write_i1profiler(
    path: Path, ids: list[str], wavelengths: np.ndarray, values: np.ndarray
) -> None:
    """CGATS as i1Profiler writes it: SampleID a number, SAMPLE_NAME the id, percent."""
    nms = [round(float(w)) for w in wavelengths]
    lines = [
        "CGATS.17", 'ORIGINATOR "i1Profiler"', "KEYWORD \"SampleID\"", "KEYWORD \"SAMPLE_NAME\"",
        f"NUMBER_OF_FIELDS {len(nms) + 2}", "BEGIN_DATA_FORMAT",
        "SampleID SAMPLE_NAME " + " ".join(f"SPECTRAL_NM{nm}" for nm in nms),
        "END_DATA_FORMAT", f"NUMBER_OF_SETS {len(ids)}", "BEGIN_DATA",
    ]  # fmt: skip
    for n, (name, row) in enumerate(zip(ids, values, strict=True)):
        lines.append(f'{n + 1} "{name}" ' + " ".join(f"{v * 100:.4f}" for v in row))
    lines.append("END_DATA")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_argyll(path: Path, ids: list[str], wavelengths: np.ndarray, values: np.ndarray) -> None:
    """CGATS as an ArgyllCMS .ti3 holds it (SAMPLE_ID, SPEC_400 ...), here as fractions."""
    nms = [round(float(w)) for w in wavelengths]
    lines = [
        "CTI3", 'DESCRIPTOR "Argyll Calibration Target chart information 3"',
        f"SPECTRAL_BANDS \"{len(nms)}\"", f"SPECTRAL_START_NM \"{nms[0]}\"",
        f"SPECTRAL_END_NM \"{nms[-1]}\"", "NUMBER_OF_FIELDS 32", "BEGIN_DATA_FORMAT",
        "SAMPLE_ID " + " ".join(f"SPEC_{nm}" for nm in nms),
        "END_DATA_FORMAT", f"NUMBER_OF_SETS {len(ids)}", "BEGIN_DATA",
    ]  # fmt: skip
    for name, row in zip(ids, values, strict=True):
        lines.append(f"{name} " + " ".join(f"{v:.6f}" for v in row))
    lines.append("END_DATA")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def random_stacks(roles: tuple[str, ...], n: int, seed: int = 3) -> list[Patch]:
    """`n` stacks of 1-3 random mixes, 0.05-1.5 mm each, over deep white or black."""
    rng = np.random.default_rng(seed)
    m = len(roles)
    eye = np.eye(m)
    stacks = []
    for i in range(n):
        count = int(rng.integers(1, 4))
        mixes = rng.dirichlet(np.full(m, 0.5), count)
        thickness = rng.uniform(0.05, 1.5, count)
        base = eye[roles.index("white" if rng.random() < 0.5 else "black")]
        stacks.append(Patch(f"S{i}", np.vstack([mixes, base]), np.append(thickness, 3.0)))
    return stacks
