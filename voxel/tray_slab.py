"""One Z slab of a build tray: several models' stacks pasted into one grid as tiles.

Each model of a tray keeps its own :class:`shellvox.voxel.slab.StackModel` and its own grid, in its
own coordinates, exactly as a build of that model alone would have them; the tray grid
holds each model grid at an integer voxel offset. :func:`compute_tray_slab` computes the
rows of every tile that meets the slab with :func:`shellvox.voxel.slab.compute_slab` and pastes
them into the tray's arrays (void elsewhere), so a tile is byte for byte the model's own
stack. That equals the stack of all models together where no voxel lies within the
deepest layer plus the signed-distance band of another model's surface: the tray's
layout keeps models that far apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shellvox.voxel.grid import GridSpec
from shellvox.voxel.slab import LayerRule, SlabResult, StackModel, compute_slab


class TrayError(ValueError):
    """A tray whose tiles do not fit together (models, grids or offsets)."""


@dataclass(frozen=True, eq=False)
class TrayStack:
    """Models of a tray, each with its own grid, placed in the tray grid as tiles.

    Parameters
    ----------
    models : tuple of StackModel
        Each model in its own coordinates (copies may share one model); all have the
        same number of bands ``K``, colour layers, layer rule and level-set half width.
    grids : tuple of GridSpec
        Each model's own grid (the grid a build of that model alone would have); all
        with the tray grid's voxel size.
    offsets_zyx : tuple of (int, int, int)
        Index of each model grid's voxel ``(0, 0, 0)`` in the tray grid; tiles do not
        overlap.
    """

    models: tuple[StackModel, ...]
    grids: tuple[GridSpec, ...]
    offsets_zyx: tuple[tuple[int, int, int], ...]

    def __post_init__(self) -> None:
        n = len(self.models)
        if n == 0 or len(self.grids) != n or len(self.offsets_zyx) != n:
            raise TrayError(
                f"models, grids and offsets_zyx must have one entry per model (at least one), "
                f"got {n}, {len(self.grids)} and {len(self.offsets_zyx)}"
            )
        first = self.models[0]
        for index, model in enumerate(self.models):
            same = (
                model.n_bands == first.n_bands
                and model.colour_layers == first.colour_layers
                and model.layer_rule == first.layer_rule
                and model.sdf_half_width_mm == first.sdf_half_width_mm
            )
            if not same:
                raise TrayError(
                    f"model {index} has {model.n_bands} bands, colour layers "
                    f"{model.colour_layers}, rule {model.layer_rule!r} and half width "
                    f"{model.sdf_half_width_mm}; model 0 has {first.n_bands}, "
                    f"{first.colour_layers}, {first.layer_rule!r} and "
                    f"{first.sdf_half_width_mm}: every model of a tray needs the same"
                )
        lower = np.array(self.offsets_zyx, dtype=np.int64).reshape(n, 3)
        if np.any(lower < 0):
            raise TrayError(f"offsets_zyx must be >= 0, got {self.offsets_zyx}")
        upper = lower + np.array([g.shape_zyx for g in self.grids], dtype=np.int64)
        overlap = np.all(
            (lower[:, None, :] < upper[None, :, :]) & (lower[None, :, :] < upper[:, None, :]),
            axis=2,
        )
        np.fill_diagonal(overlap, False)
        if np.any(overlap):
            a, b = (int(i) for i in np.argwhere(overlap)[0])
            raise TrayError(f"the tiles of models {a} and {b} overlap in the tray grid")

    @property
    def n_bands(self) -> int:
        """Number of shell bands ``K`` (the core is layer ``K + 1``)."""
        return self.models[0].n_bands

    @property
    def colour_layers(self) -> tuple[int, ...]:
        """Layers (1..K+1) whose voxels take the nearest surface colour."""
        return self.models[0].colour_layers

    @property
    def layer_rule(self) -> LayerRule:
        """How voxels get their layer (the same for every model)."""
        return self.models[0].layer_rule

    @property
    def sdf_half_width_mm(self) -> float:
        """Half width (mm) of the level set's narrow band."""
        return self.models[0].sdf_half_width_mm


def compute_tray_slab(tray: TrayStack, grid: GridSpec, z_start: int, z_stop: int) -> SlabResult:
    """Return layers, colours and the signed-distance band of rows ``z_start..z_stop``.

    Parameters
    ----------
    tray : TrayStack
        The models, their grids and their offsets in `grid`.
    grid : GridSpec
        The tray grid; every tile lies inside it.
    z_start, z_stop : int
        Rows of the slab, ``0 <= z_start < z_stop <= Z``.

    Returns
    -------
    SlabResult
        Arrays of shape ``(z_stop - z_start, Y, X)``: each tile's rows as
        :func:`shellvox.voxel.slab.compute_slab` gives them for its model and grid; outside the
        tiles layer 0, colour 0, signed distance ``+half_width`` and no band. Counts and
        diagnostics are the tiles' sums (outside voxels counted in layer 0).
    """
    n_z, n_y, n_x = grid.shape_zyx
    if not 0 <= z_start < z_stop <= n_z:
        raise ValueError(
            f"slab rows must satisfy 0 <= z_start < z_stop <= {n_z}, got {z_start}, {z_stop}"
        )
    for index, (model_grid, offset) in enumerate(zip(tray.grids, tray.offsets_zyx, strict=True)):
        inside = all(
            o + s <= n for o, s, n in zip(offset, model_grid.shape_zyx, grid.shape_zyx, strict=True)
        )
        if not inside or not np.allclose(model_grid.voxel_mm, grid.voxel_mm, rtol=1e-12):
            raise ValueError(
                f"model {index}'s grid ({model_grid.shape_zyx} voxels of {model_grid.voxel_mm} mm "
                f"at offset {offset}) must lie inside the tray grid {grid.shape_zyx} of "
                f"{grid.voxel_mm} mm voxels"
            )
    shape = (z_stop - z_start, n_y, n_x)
    layers = np.zeros(shape, dtype=np.uint8)
    rgba = np.zeros((*shape, 4), dtype=np.uint8)
    sdf = np.full(shape, tray.sdf_half_width_mm, dtype=np.float32)
    sdf_band = np.zeros(shape, dtype=bool)
    counts = np.zeros(tray.n_bands + 2, dtype=np.int64)
    unbalanced = violations = queries = tests = tiled = 0
    for model, model_grid, (oz, oy, ox) in zip(
        tray.models, tray.grids, tray.offsets_zyx, strict=True
    ):
        tz, ty, tx = model_grid.shape_zyx
        low, high = max(z_start, oz), min(z_stop, oz + tz)
        if low >= high:
            continue
        part = compute_slab(model, model_grid, low - oz, high - oz)
        where = (slice(low - z_start, high - z_start), slice(oy, oy + ty), slice(ox, ox + tx))
        layers[where] = part.layers
        rgba[where] = part.rgba
        sdf[where] = part.sdf
        sdf_band[where] = part.sdf_band
        counts += part.layer_counts
        tiled += part.layers.size
        unbalanced += part.n_unbalanced_rows
        violations += part.n_nesting_violations
        queries += part.n_nearest_queries
        tests += part.n_distance_tests
    counts[0] += layers.size - tiled
    return SlabResult(
        z_start,
        z_stop,
        layers,
        rgba,
        sdf,
        sdf_band,
        unbalanced,
        violations,
        queries,
        tests,
        counts,
    )
