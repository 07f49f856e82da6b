"""What the viewer's requests ask of a build: slice regions, depth, one voxel's read-out.

A slice region is rows and columns (index ranges with a step) of the slice at
``index`` along ``axis``: rows are y for a z slice and z for y and x slices, columns x
for z and y slices and y for x slices, row 0 the lowest index. The page draws it at
the voxels' true size in millimetres; the step is how many voxels one screen pixel
covers, so a zoomed-out view reads a fraction of the pages.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from skimage.color import rgb2lab

from shellvox.viewer._folder import BuildFolder
from shellvox.viewer._stacks import Axis

#: Largest region served at once (pixels): a 4K screen at one voxel per pixel.
MAX_PIXELS = 3840 * 2160

#: What a slice request can read: a stack, or the depth computed from the surface.
KINDS = ("layers", "colour", "materials", "depth")


class RequestError(ValueError):
    """A request's parameters are missing, malformed or outside the grid."""


@dataclass(frozen=True)
class SliceRegion:
    """Rows and columns of one slice (see the module docstring)."""

    axis: Axis
    index: int
    rows: range
    cols: range

    @classmethod
    def from_query(
        cls, query: Mapping[str, Sequence[str]], shape_zyx: Sequence[int]
    ) -> SliceRegion:
        """Parse ``axis, index, r0, r1, rs, c0, c1, cs`` (stop exclusive, clipped to the grid).

        Raises
        ------
        RequestError
            A parameter is missing or not an integer, the axis is not z, y or x, the
            index is outside the grid, a step is below 1 or the region too large.
        """
        axis = _one(query, "axis")
        if axis not in ("z", "y", "x"):
            raise RequestError(f"axis must be z, y or x, got {axis!r}")
        n_z, n_y, n_x = (int(n) for n in shape_zyx)
        extent = {"z": n_z, "y": n_y, "x": n_x}
        row_axis, col_axis = {"z": ("y", "x"), "y": ("z", "x"), "x": ("z", "y")}[axis]
        index = _integer(query, "index")
        if not 0 <= index < extent[axis]:
            raise RequestError(f"index {index} is outside 0..{extent[axis] - 1} along {axis}")
        spans = []
        for prefix, along in (("r", row_axis), ("c", col_axis)):
            start, stop, step = (_integer(query, prefix + part) for part in ("0", "1", "s"))
            if step < 1:
                raise RequestError(f"{prefix}s must be >= 1, got {step}")
            start, stop = max(0, start), min(extent[along], stop)
            spans.append(range(start, max(start, stop), step))
        rows, cols = spans
        if len(rows) * len(cols) > MAX_PIXELS:
            raise RequestError(
                f"the region has {len(rows)} x {len(cols)} pixels, more than {MAX_PIXELS:,}: "
                "ask with a larger step"
            )
        return cls(axis, index, rows, cols)  # type: ignore[arg-type]

    def header(self) -> str:
        """Return the region as ``axis index r0 r1 rs c0 c1 cs`` (echoed to the page)."""
        r, c = self.rows, self.cols
        return f"{self.axis} {self.index} {r.start} {r.stop} {r.step} {c.start} {c.stop} {c.step}"


def _one(query: Mapping[str, Sequence[str]], name: str) -> str:
    values = query.get(name)
    if not values or len(values) != 1:
        raise RequestError(f"give one {name}=")
    return values[0]


def _integer(query: Mapping[str, Sequence[str]], name: str) -> int:
    text = _one(query, name)
    if not text.lstrip("-").isdigit() or len(text) > 12:
        raise RequestError(f"{name} must be an integer, got {text!r}")
    return int(text)


def read_region(folder: BuildFolder, kind: str, region: SliceRegion) -> NDArray[Any]:
    """Return a slice region of a stack, or the depth there.

    Parameters
    ----------
    folder : BuildFolder
        The open build.
    kind : {"layers", "colour", "materials", "depth"}
        A stack (uint8 ``(H, W)``, colour ``(H, W, S)``), or ``depth``: float32
        ``(H, W, 2)``, the distance to the surface (mm) and the colour-layer thickness
        of the nearest face (mm) of every shell-band voxel, NaN elsewhere.

    Raises
    ------
    RequestError
        The build has no such stack (or no surface for depth).
    """
    if kind == "depth":
        return depth_region(folder, region)
    if kind not in folder.stacks:
        raise RequestError(f"this build has no {kind} stack")
    return folder.stacks[kind].region(region.axis, region.index, region.rows, region.cols)


def region_indices(region: SliceRegion) -> tuple[NDArray[np.int64], ...]:
    """Return the ``(z, y, x)`` index of every pixel of a region, each ``(H, W)`` int64."""
    rows = np.asarray(region.rows, dtype=np.int64)[:, None]
    cols = np.asarray(region.cols, dtype=np.int64)[None, :]
    fixed = np.int64(region.index)
    rows, cols = np.broadcast_arrays(rows, cols)
    if region.axis == "z":
        return np.full_like(rows, fixed), rows, cols
    if region.axis == "y":
        return rows, np.full_like(rows, fixed), cols
    return rows, cols, np.full_like(rows, fixed)


def depth_region(folder: BuildFolder, region: SliceRegion) -> NDArray[np.float32]:
    """Depth and nearest-face colour-layer thickness of the band voxels of a region.

    Returns
    -------
    (H, W, 2) float32, mm
        NaN outside the model and in the core (whose depth is only "deeper than the
        last band").
    """
    if folder.surface is None:
        raise RequestError("this build has no thickness.ply, so no depth (built with --thickness)")
    layers = folder.stacks["layers"].region(region.axis, region.index, region.rows, region.cols)
    in_band = (layers >= 1) & (layers <= len(folder.layers) - 2)
    result = np.full((*layers.shape, 2), np.nan, dtype=np.float32)
    z, y, x = (axis[in_band] for axis in region_indices(region))
    points = folder.grid.index_to_world(np.stack([z, y, x], axis=1))
    depth, faces = folder.surface.nearest(points)
    result[in_band, 0] = depth
    result[in_band, 1] = folder.surface.colour_layer_mm[faces]
    return result


def probe(folder: BuildFolder, z: int, y: int, x: int) -> dict[str, Any]:
    """Return everything known about voxel ``(z, y, x)`` (JSON-ready).

    Keys: ``index_zyx``; ``position_mm`` (its centre ``(x, y, z)``); ``layer`` (index,
    name, colour); ``colour`` (sRGB 0..255, alpha if stored, CIELAB D65 ``L*a*b*``;
    None outside the colour layers, whose colour.tif value is 0); ``material`` (index,
    name; None without materials.tif); ``depth`` (distance to the surface in mm, whether
    the voxel is inside, the nearest face, its colour-layer thickness and its layers'
    cumulative depth limits; None without thickness.ply).
    """
    n_z, n_y, n_x = folder.grid.shape_zyx
    if not (0 <= z < n_z and 0 <= y < n_y and 0 <= x < n_x):
        raise RequestError(f"voxel ({z}, {y}, {x}) is outside the grid {n_z} x {n_y} x {n_x}")
    centre = folder.grid.index_to_world(np.array([[z, y, x]]))[0]
    layer_index = int(folder.stacks["layers"].voxel(z, y, x)[0])
    layer = next((item for item in folder.layers if item.index == layer_index), None)
    result: dict[str, Any] = {
        "index_zyx": [z, y, x],
        "position_mm": [float(v) for v in centre],
        "layer": {
            "index": layer_index,
            "name": layer.name if layer else f"unknown layer {layer_index}",
            "colour": bool(layer and layer.colour),
        },
        "colour": None,
        "material": None,
        "depth": None,
    }
    if layer is not None and layer.colour:
        value = folder.stacks["colour"].voxel(z, y, x)
        rgb = [int(v) for v in value[:3]]
        lab = rgb2lab(np.array([[rgb]], dtype=np.float64) / 255.0, illuminant="D65")[0, 0]
        result["colour"] = {
            "srgb": rgb,
            "alpha": int(value[3]) if len(value) > 3 else None,
            "lab": [float(v) for v in lab],
        }
    if "materials" in folder.stacks:
        index = int(folder.stacks["materials"].voxel(z, y, x)[0])
        material = next((m for m in folder.materials if m.index == index), None)
        result["material"] = {
            "index": index,
            "name": material.name if material else f"material {index}",
        }
    if folder.surface is not None:
        distance, f = folder.surface.deciding_face(centre)
        result["depth"] = {
            "mm": distance,
            "inside": layer_index != 0,
            "face": f,
            "colour_layer_mm": float(folder.surface.colour_layer_mm[f]),
            "layer_limits_mm": [float(v) for v in np.cumsum(folder.surface.thickness_mm[:, f])],
        }
    return result
