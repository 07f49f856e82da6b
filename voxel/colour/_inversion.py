"""Separation by inverting the two-flux model: the mix whose deep layer shows the target.

For a target colour (CIELAB under D50, from sRGB by :func:`kubelka_munk.srgb_to_lab_d50`),
the proportions ``p`` of the opaque materials (non-negative, summing to 1) are those
whose mixture, infinitely deep and under the resin surface, is closest to it in
CIEDE2000:

    minimise  dE00(Lab(p), target)^2 + w * sum_i p_i |Lab_i - target|^2

``Lab(p)`` is Saunderson's reflectance of ``R_inf(p K, p S)`` (Duncan's mixing) seen
under D50. The second term, with a small weight ``w``, breaks the ties among the exact
mixes (five materials, three colour coordinates) towards the least visible grain, as
the linear separation does. A target outside the reachable colours goes to the mix of
least CIEDE2000 (minimum-dE clipping); that residual is the *gamut error*, reported
apart from the model's and the reproduction's errors.

The solver is vectorised over all targets: the best of a grid of mixes on the simplex
(its ``k`` nearest in CIELAB, then CIEDE2000), then projected descent on the simplex with
finite-difference gradients and a per-target step that grows on success and halves on
failure.

Every choice the solver makes compares costs rounded to :data:`COST_QUANTUM`, far above
the last-bit differences between processors (vector instructions, BLAS kernels), and
breaks ties by a strict order: the start of least rounded cost, then of lowest row of
the grid; a step is taken only when its rounded cost is lower. Near-equal mixes (several
mixes reach one colour) are therefore chosen alike on every machine, and the solved
mixes of two machines differ only where the descent stops short in a flat valley, by a
fraction of a CIEDE2000 unit.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import colour
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from shellvox.voxel.colour._kubelka_munk import (
    Observer,
    observer,
    r_infinity,
    reflectance_to_lab,
    saunderson,
)
from shellvox.voxel.colour._optics import Optics

#: Weight of the grain term (CIELAB units squared) against dE00 squared: a tie-break.
GRAIN_WEIGHT = 1e-5

#: Steps of the simplex grid of starting mixes (1/n), candidates per target, descent steps.
START_DIVISIONS = 10
START_CANDIDATES = 16
ITERATIONS = 30
FD_STEP = 1e-5

#: Shares of the log-spaced starting mixes (a base material with small shares of others).
LOG_SHARES = (0.0, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0)

#: Share of the uniform mix blended into the start (no share starts at exactly 0).
START_BLEND = 1e-3

#: Smallest share the descent keeps (shares below ten times it end as 0).
MIN_SHARE = 1e-9

#: Costs (CIEDE2000 squared) are compared rounded to this: two mixes whose costs round
#: alike are equally good and the tie-break decides. Float noise in a cost is about 1e-12.
COST_QUANTUM = 1e-6


class Inversion(NamedTuple):
    """Mixes for targets.

    Attributes
    ----------
    proportions : (N, P) float64
        Share of each opaque material, rows on the simplex.
    lab : (N, 3) float64
        CIELAB of each mix, deep and under the surface.
    delta_e : (N,) float64
        CIEDE2000 between the mix and its target (the gamut error where large).
    """

    proportions: NDArray[np.float64]
    lab: NDArray[np.float64]
    delta_e: NDArray[np.float64]


class DeepColour:
    """CIELAB of deep layers of mixes of some of a printer's materials.

    Parameters
    ----------
    optics : Optics
    columns : sequence of int
        Materials (rows of ``optics``) the proportions refer to, in order.
    """

    def __init__(self, optics: Optics, columns: ArrayLike) -> None:
        index = np.asarray(columns, np.int64)
        self.k = optics.k_per_mm[index]
        self.s = optics.s_per_mm[index]
        self.k1, self.k2 = optics.k1, optics.k2
        self.seen: Observer = observer(optics.wavelengths_nm)

    def __call__(self, proportions: ArrayLike) -> NDArray[np.float64]:
        """CIELAB ``(..., 3)`` of mixes ``(..., P)``."""
        p = np.asarray(proportions, np.float64)
        body = r_infinity(p @ self.k, p @ self.s)
        return reflectance_to_lab(saunderson(body, self.k1, self.k2), self.seen)


def project_to_simplex(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Euclidean projection of each row of ``(N, P)`` onto the probability simplex."""
    u = -np.sort(-v, axis=1)
    cssv = np.cumsum(u, axis=1) - 1.0
    j = np.arange(1, v.shape[1] + 1)
    rho = (u - cssv / j > 0).sum(axis=1)
    theta = cssv[np.arange(len(v)), rho - 1] / rho
    return np.asarray(np.maximum(v - theta[:, None], 0.0), np.float64)


def _start(deep: DeepColour, target: NDArray[np.float64], cost: Any) -> NDArray[np.float64]:
    """Return the best of a grid of mixes for each target (nearest in CIELAB, then cost)."""
    n_materials = deep.k.shape[0]
    grid = np.concatenate(
        [simplex_grid(n_materials, START_DIVISIONS)]
        + [np.roll(log_grid(n_materials, LOG_SHARES), b, axis=1) for b in range(n_materials)]
    )
    grid_lab = deep(grid)
    _, nearest = cKDTree(grid_lab).query(target, k=min(START_CANDIDATES, len(grid)))
    rows = np.repeat(np.arange(len(target)), nearest.shape[1])
    start_cost = cost(grid[nearest.ravel()], grid_lab[nearest.ravel()], rows)
    # least rounded cost, then lowest grid row: independent of the tree's order of ties
    best = np.lexsort((nearest, cost_rank(start_cost.reshape(nearest.shape))))[:, 0]
    return np.asarray(grid[nearest[np.arange(len(target)), best]], np.float64)


def cost_rank(cost: ArrayLike) -> NDArray[np.float64]:
    """Return costs rounded to whole multiples of :data:`COST_QUANTUM` (the solver compares these).

    Parameters
    ----------
    cost : (...) float
        Costs, CIEDE2000 squared plus the grain term.

    Returns
    -------
    (...) float64
        ``round(cost / COST_QUANTUM)``: equal for costs that count as equally good.
    """
    return np.asarray(np.round(np.asarray(cost, np.float64) / COST_QUANTUM), np.float64)


def _softmax(z: NDArray[np.float64]) -> NDArray[np.float64]:
    e = np.exp(z - z.max(1, keepdims=True))
    return np.asarray(e / e.sum(1, keepdims=True), np.float64)


def log_grid(n_materials: int, shares: ArrayLike) -> NDArray[np.float64]:
    """Return mixes ``(C, n_materials)``: the first shares from `shares`, the last the rest.

    Rows over 1 are scaled to sum 1. A start for mixes of a base with small shares of
    strong colourants.
    """
    values = np.asarray(shares, np.float64)
    axes = np.stack(np.meshgrid(*[values] * (n_materials - 1), indexing="ij"), -1)
    axes = axes.reshape(-1, n_materials - 1)
    total = axes.sum(1, keepdims=True)
    axes = np.where(total > 1, axes / np.maximum(total, 1e-300), axes)
    return np.column_stack([axes, 1 - axes.sum(1)])


def simplex_grid(n_materials: int, divisions: int) -> NDArray[np.float64]:
    """Every mix with proportions in steps of ``1 / divisions``, ``(C, n_materials)``."""
    axes = np.stack(
        np.meshgrid(*[np.arange(divisions + 1)] * (n_materials - 1), indexing="ij"), -1
    ).reshape(-1, n_materials - 1)
    axes = axes[axes.sum(1) <= divisions]
    return np.column_stack([axes, divisions - axes.sum(1)]) / divisions


def invert(
    deep: DeepColour,
    targets: ArrayLike,
    *,
    grain_weight: float = GRAIN_WEIGHT,
    iterations: int = ITERATIONS,
) -> Inversion:
    """Return the mix of least CIEDE2000 (with the grain tie-break) for each target.

    Parameters
    ----------
    deep : DeepColour
        The model of the materials' deep layers.
    targets : (N, 3) float
        CIELAB targets (under the model's white).
    grain_weight : float
        Weight of the grain term.
    iterations : int
        Descent steps.
    """
    target = np.asarray(targets, np.float64).reshape(-1, 3)
    n_materials = deep.k.shape[0]
    pure = deep(np.eye(n_materials))  # (P, 3)
    grain = ((pure[None] - target[:, None]) ** 2).sum(-1)  # (N, P): linear in p

    def cost(
        p: NDArray[np.float64], lab: NDArray[np.float64], rows: NDArray[np.int64]
    ) -> NDArray[np.float64]:
        de = colour.delta_E(lab, target[rows], method="CIE 2000")
        return np.asarray(de**2 + grain_weight * (p * grain[rows]).sum(-1), np.float64)

    p = _start(deep, target, cost)
    every = np.arange(len(target))
    # Descent in z = log p (p = softmax z): a colourant's effect follows the *ratio* of its
    # share, over orders of magnitude, so steps in z move tiny and large shares alike.
    p = (1 - START_BLEND) * p + START_BLEND / n_materials  # every share can grow
    z = np.log(p)
    lab = deep(p)
    f = cost(p, lab, every)
    damping = np.full(len(target), 1e-2)
    step = np.full(len(target), 1.0)
    floor = np.log(MIN_SHARE)
    for _ in range(iterations):  # descent steps, all targets at once
        probes = [_softmax(z + FD_STEP * np.eye(n_materials)[i]) for i in range(n_materials)]
        probe_lab = [deep(q) for q in probes]
        jacobian = np.stack([(b - lab) / FD_STEP for b in probe_lab], -1)  # (N, 3, P)
        gradient = np.stack(
            [(cost(q, b, every) - f) / FD_STEP for q, b in zip(probes, probe_lab, strict=True)],
            1,
        )
        # Levenberg-Marquardt on the CIELAB residual (least-norm step, 3 equations)...
        normal = jacobian @ jacobian.transpose(0, 2, 1) + damping[:, None, None] * np.eye(3)
        residual = (lab - target)[..., None]
        z_lm = np.maximum(
            z - (jacobian.transpose(0, 2, 1) @ np.linalg.solve(normal, residual))[..., 0], floor
        )
        # ... and a normalised gradient step on the whole cost (grain included).
        norm = np.linalg.norm(gradient, axis=1)
        direction = gradient / np.where(norm > 0, norm, 1.0)[:, None]
        z_gd = np.maximum(z - step[:, None] * direction, floor)
        for z_trial, kind in ((z_lm, "lm"), (z_gd, "gd")):
            trial = _softmax(z_trial)
            trial_lab = deep(trial)
            f_trial = cost(trial, trial_lab, every)
            better = cost_rank(f_trial) < cost_rank(f)  # a tie keeps the current mix
            z = np.where(better[:, None], z_trial, z)
            p = np.where(better[:, None], trial, p)
            lab = np.where(better[:, None], trial_lab, lab)
            f = np.where(better, f_trial, f)
            if kind == "lm":
                damping = np.where(better, damping * 0.3, damping * 4.0).clip(1e-8, 1e8)
            else:
                step = np.where(better, np.minimum(step * 1.5, 4.0), step * 0.5)
    p = np.where(p < 10 * MIN_SHARE, 0.0, p)
    p /= p.sum(1, keepdims=True)
    lab = deep(p)
    return Inversion(p, lab, np.asarray(colour.delta_E(lab, target, method="CIE 2000")))
