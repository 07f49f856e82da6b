"""The soft proof: a build's printed colour, predicted from its voxels, at surface samples.

:class:`SoftProof` holds, at ``N`` points of the model's surface, four colours and three
errors (CIEDE2000), all from the colour report's columns
(:class:`~shellvox.voxel.colour._model_report.ModelReport`):

- ``target_lab``: the model's colour;
- ``aim_lab``: the colour the separation aims at (its mix, infinitely deep);
- ``predicted_lab``: the colour the two-flux model predicts from the halftoned material
  voxels as written under the point (NaN where no material voxel was read);
- ``gamut_de`` (aim against target: what no printing of these materials reaches),
  ``reproduction_de`` (prediction against aim: halftone, voxels and depth) and
  ``total_de`` (prediction against target).

CIELAB is relative to the optics' white (D50 for the shipped profiles), as the colour
report's. The samples are drawn uniformly by area at a density that resolves a 1 mm
colour patch (:data:`PROOF_SAMPLES_PER_MM2`); the lateral reach of the light under each
point (0.25 to 1 mm) already averages the prediction over at least that scale.

Between samples, :meth:`SoftProof.at` interpolates: the :data:`NEIGHBOURS` nearest samples
within :data:`REACH_SPACINGS` mean spacings whose normals face the query's side (their dot
product above :data:`SAME_SIDE`, so a thin wall's two faces stay apart), weighted by the
inverse square of their distance (Shepard's interpolation: a sample's own value at the
sample, a blend of the nearest between them).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.voxel.colour._kubelka_munk import lab_d50_to_srgb8

#: Surface samples per mm^2 of the soft proof: a mean spacing of 0.29 mm, about 12
#: samples in a 1 mm colour patch.
PROOF_SAMPLES_PER_MM2 = 12.0
#: At most this many proof samples (about 1 kB each while the slabs stream, counted in
#: the build's memory estimate); beyond it the spacing grows, as the manifest states.
PROOF_MAX_SAMPLES = 250_000
#: CIEDE2000 from the gamut within which a target counts as in gamut.
IN_GAMUT_DE = 1.0
#: Samples an interpolated value is made from, at most.
NEIGHBOURS = 8
#: Samples farther than this many mean spacings from a query do not count.
REACH_SPACINGS = 3.0
#: Distances below this count as this (mm): a query at a sample takes its value.
SAME_POINT_MM = 1e-6
#: A sample counts for a query when their unit normals' dot product is above this.
SAME_SIDE = 0.3


@dataclass(frozen=True, eq=False)
class SoftProof:
    """Predicted printed colour and its errors at surface points (see the module).

    Attributes
    ----------
    points_mm : (N, 3) float64, mm
        Surface points ``(x, y, z)``.
    normals : (N, 3) float64
        Unit outward normals.
    target_lab, aim_lab, predicted_lab : (N, 3) float64
        CIELAB (the optics' white) of the target, the separation's aim and the
        prediction from the voxels (NaN where nothing was predicted).
    total_de, gamut_de, reproduction_de : (N,) float64
        CIEDE2000: prediction against target, aim against target, prediction against
        aim (NaN where nothing was predicted).
    spacing_mm : float, mm
        Mean spacing of the samples the values come from (``sqrt(area / samples)``).
    white_xy : (2,) float64
        Chromaticity of the CIELAB white.
    optics : str
        ``"assumed"`` (the profile's default optics) or ``"measured"`` (a calibrated
        profile).
    """

    points_mm: NDArray[np.float64]
    normals: NDArray[np.float64]
    target_lab: NDArray[np.float64]
    aim_lab: NDArray[np.float64]
    predicted_lab: NDArray[np.float64]
    total_de: NDArray[np.float64]
    gamut_de: NDArray[np.float64]
    reproduction_de: NDArray[np.float64]
    spacing_mm: float
    white_xy: NDArray[np.float64]
    optics: str

    #: The per-sample arrays.
    ARRAYS = (
        "points_mm",
        "normals",
        "target_lab",
        "aim_lab",
        "predicted_lab",
        "total_de",
        "gamut_de",
        "reproduction_de",
    )

    def __len__(self) -> int:
        return len(self.points_mm)

    def __repr__(self) -> str:
        """One line: the samples, how many were predicted, the median CIEDE2000, the optics."""
        found = self.predicted
        median = float(np.median(self.total_de[found])) if found.any() else float("nan")
        return (
            f"SoftProof({len(self)} points, {int(found.sum())} predicted, median total_de "
            f"{median:.2f}, spacing_mm={self.spacing_mm:.3g}, optics={self.optics!r})"
        )

    @property
    def predicted(self) -> NDArray[np.bool_]:
        """``(N,) bool``: a prediction exists (material voxels were read under the point)."""
        found: NDArray[np.bool_] = np.all(np.isfinite(self.predicted_lab), axis=1)
        return found

    @property
    def in_gamut(self) -> NDArray[np.bool_]:
        """``(N,) bool``: the target is within :data:`IN_GAMUT_DE` of the gamut."""
        inside: NDArray[np.bool_] = self.gamut_de <= IN_GAMUT_DE
        return inside

    def srgb(self, which: str = "predicted") -> NDArray[np.uint8]:
        """Return ``(N, 3) uint8`` sRGB of ``"predicted"``, ``"target"`` or ``"aim"``.

        Colours outside sRGB are clipped; grey ``(160, 160, 160)`` where there is none.
        """
        if which not in ("predicted", "target", "aim"):
            raise ValueError(f"which must be 'predicted', 'target' or 'aim', got {which!r}")
        lab = getattr(self, f"{which}_lab")
        out = np.full((len(lab), 3), 160, np.uint8)
        known = np.all(np.isfinite(lab), axis=1)
        if known.any():
            out[known] = lab_d50_to_srgb8(lab[known], self.white_xy)
        return out

    def at(
        self, points_mm: ArrayLike, normals: ArrayLike, *, same_side: float = SAME_SIDE
    ) -> SoftProof:
        """Return the proof interpolated at other surface points (see the module).

        Parameters
        ----------
        points_mm : (M, 3) array_like of float, mm
            Points on (or within a voxel or two of) the surface.
        normals : (M, 3) or (3,) array_like of float
            Their outward normals, or one direction for all (a view's: towards the
            viewer); only samples facing the same side count.
        same_side : float
            A sample counts when its normal's dot product with the query's is above this
            (:data:`SAME_SIDE`; 0 for a view's direction: every sample facing the viewer).

        Returns
        -------
        SoftProof
            Values at the `M` points; NaN where no sample is near enough (farther than
            ``REACH_SPACINGS * spacing_mm``, or none on the same side). Its ``normals``
            are the queries' (unit length; a view's direction repeated).

        Examples
        --------
        A proof on the plane ``z = 0``, samples 0.1 mm apart, predicted ``L* = 51`` and
        ``a* = 20 x``:

        >>> import numpy as np
        >>> from shellvox.voxel.colour import SoftProof
        >>> ticks = np.arange(-1.0, 1.05, 0.1)
        >>> xy = np.stack(np.meshgrid(ticks, ticks), -1).reshape(-1, 2)
        >>> n = len(xy)
        >>> lab = np.column_stack([np.full(n, 50.0), 20.0 * xy[:, 0], np.zeros(n)])
        >>> proof = SoftProof(
        ...     points_mm=np.column_stack([xy, np.zeros(n)]),
        ...     normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
        ...     target_lab=lab,
        ...     aim_lab=lab,
        ...     predicted_lab=lab + [1.0, 0.0, 0.0],
        ...     total_de=np.ones(n),
        ...     gamut_de=np.zeros(n),
        ...     reproduction_de=np.ones(n),
        ...     spacing_mm=0.1,
        ...     white_xy=np.array([0.3457, 0.3585]),
        ...     optics="assumed",
        ... )
        >>> near = proof.at([[0.0, 0.0, 0.01]], [0.0, 0.0, 1.0])  # near x = 0: a* near 0
        >>> near.predicted_lab[0].round(1).tolist(), float(near.total_de[0])
        ([51.0, 0.0, 0.0], 1.0)
        >>> bool(np.isnan(proof.at([[9.0, 9.0, 9.0]], [0.0, 0.0, 1.0]).total_de[0]))
        True
        """
        from scipy.spatial import cKDTree

        queries = np.asarray(points_mm, np.float64).reshape(-1, 3)
        facing = np.broadcast_to(np.asarray(normals, np.float64), queries.shape)
        facing = facing / np.maximum(np.linalg.norm(facing, axis=1, keepdims=True), 1e-300)
        k = min(NEIGHBOURS, len(self))
        values = {name: getattr(self, name) for name in self.ARRAYS[2:]}
        out = {name: np.full((len(queries), *v.shape[1:]), np.nan) for name, v in values.items()}
        if k == 0 or len(queries) == 0:
            return self._with(queries, facing, out)
        reach = REACH_SPACINGS * self.spacing_mm
        tree = cKDTree(self.points_mm)
        for start in range(0, len(queries), 1 << 16):  # memory: (chunk, k) at a time
            chunk = slice(start, start + (1 << 16))
            distance, index = tree.query(queries[chunk], k=k, distance_upper_bound=reach)
            distance, index = distance.reshape(-1, k), index.reshape(-1, k)
            near = index < len(self)
            index = np.where(near, index, 0)
            same = np.einsum("mkc,mc->mk", self.normals[index], facing[chunk]) > same_side
            inverse = 1.0 / np.maximum(distance, SAME_POINT_MM) ** 2
            weight = np.where(near & same, inverse, 0.0)
            for name, value in values.items():
                gathered = value[index]  # (m, k) or (m, k, 3)
                w = weight if gathered.ndim == 2 else weight[..., None]
                known = np.isfinite(gathered)
                w = np.where(known, w, 0.0)
                total = w.sum(axis=1)
                mean = np.where(known, gathered, 0.0)
                summed = (w * mean).sum(axis=1)
                out[name][chunk] = np.divide(
                    summed, total, out=np.full_like(summed, np.nan), where=total > 0
                )
        return self._with(queries, facing, out)

    def _with(
        self,
        points: NDArray[np.float64],
        normals: NDArray[np.float64],
        values: dict[str, NDArray[np.float64]],
    ) -> SoftProof:
        changed: dict[str, Any] = {"points_mm": points, "normals": normals, **values}
        return replace(self, **changed)

    def record(self) -> dict[str, Any]:
        """Return the manifest's record of the proof (how it was made; JSON-ready)."""
        return {
            "samples": len(self),
            "predicted_samples": int(self.predicted.sum()),
            "mean_spacing_mm": self.spacing_mm,
            "model": "kubelka-munk voxel columns (the colour report's)",
            "optics": self.optics,
            "lab_white_xy": [float(v) for v in self.white_xy],
            "delta_e": "CIE 2000",
            "in_gamut_de": IN_GAMUT_DE,
            "interpolation": {
                "neighbours": NEIGHBOURS,
                "reach_spacings": REACH_SPACINGS,
                "same_side_dot": SAME_SIDE,
                "weight": "1 / distance^2 (Shepard)",
            },
        }


def _demo_proof() -> SoftProof:
    """Return a small proof on the plane ``z = 0`` (samples 0.1 mm apart; for the tests)."""
    grid = np.stack(np.meshgrid(np.arange(-1.0, 1.05, 0.1), np.arange(-1.0, 1.05, 0.1)), -1)
    points = np.concatenate([grid.reshape(-1, 2), np.zeros((grid.size // 2, 1))], axis=1)
    n = len(points)
    lab = np.column_stack([np.full(n, 50.0), 20.0 * points[:, 0], np.zeros(n)])
    return SoftProof(
        points_mm=points,
        normals=np.tile([0.0, 0.0, 1.0], (n, 1)),
        target_lab=lab,
        aim_lab=lab,
        predicted_lab=lab + np.array([1.0, 0.0, 0.0]),
        total_de=np.ones(n),
        gamut_de=np.zeros(n),
        reproduction_de=np.ones(n),
        spacing_mm=0.1,
        white_xy=np.array([0.3457, 0.3585]),
        optics="assumed",
    )
