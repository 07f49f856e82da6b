"""Generate shellvox's default model: a rounded colour-target block (OBJ + MTL + PNG).

The block is 24 x 16 x 6 mm with 1.5 mm rounded edges. Every face carries a tile of the
texture atlas with colour patches chosen to show what per-face colour-layer thickness is
for: a lightness ramp from near-black to near-white, chroma ramps from saturated to grey
at several hues, and a grey ramp. UV seams run along the block's edges, so the file also
exercises seam merging.

Run ``python data/make_colour_target.py`` to rewrite ``data/colour_target/``; the output
is deterministic.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import colour
import numpy as np
from numpy.typing import NDArray
from PIL import Image

HALF_MM = np.array([12.0, 8.0, 3.0])
RADIUS_MM = 1.5
TILE = 128  # pixels per face tile; the atlas is 3 x 2 tiles
OUT = Path(__file__).resolve().parent / "colour_target"


def _axis_coordinates(
    half: float, radius: float, n_round: int = 5, n_flat: int = 8
) -> NDArray[np.float64]:
    """Grid coordinates along one axis: dense on the rounded edges, sparse between."""
    inner = half - radius
    angles = np.linspace(0.0, np.pi / 2, n_round + 1)[1:]
    rounded = inner + radius * np.sin(angles)
    flat = np.linspace(-inner, inner, n_flat)
    return np.concatenate([-rounded[::-1], flat, rounded])


def _patches(lightness: Any, chroma: Any, hue_deg: Any) -> NDArray[np.uint8]:
    """sRGB uint8 colours of CIE LCh(ab) patches (D65), clipped into gamut."""
    lch = np.stack(np.broadcast_arrays(lightness, chroma, hue_deg), axis=-1)
    xyz = colour.Lab_to_XYZ(colour.LCHab_to_Lab(lch))  # type: ignore[attr-defined]
    rgb = colour.XYZ_to_sRGB(xyz)
    patches: NDArray[np.uint8] = np.rint(np.clip(rgb, 0, 1) * 255).astype(np.uint8)
    return patches


def _tile(kind: int) -> NDArray[np.uint8]:
    """One 4 x 4 patch tile of the atlas, with thin neutral grey gaps between patches."""
    lightness = np.linspace(12, 96, 4)
    if kind == 0:  # lightness x hue at moderate chroma
        grid = _patches(lightness[None, :], 35, np.array([0, 90, 180, 270])[:, None])
    elif kind == 1:  # chroma ramp: saturated to grey, four hues
        grid = _patches(60, np.linspace(70, 0, 4)[None, :], np.array([30, 110, 200, 300])[:, None])
    elif kind == 2:  # light, low-chroma pastels: the case that needs thick colour layers
        grid = _patches(np.linspace(80, 97, 4)[None, :], 15, np.array([20, 100, 190, 280])[:, None])
    elif kind == 3:  # grey ramp, dark to very light
        grid = _patches(np.linspace(5, 98, 16).reshape(4, 4), 0, 0)
    elif kind == 4:  # dark saturated colours
        grid = _patches(np.linspace(20, 45, 4)[None, :], 50, np.array([10, 140, 230, 320])[:, None])
    else:  # skin-like and earth tones
        grid = _patches(np.linspace(35, 85, 4)[None, :], np.linspace(10, 40, 4)[:, None], 55)
    cell = TILE // 4
    image = np.full((TILE, TILE, 3), 128, dtype=np.uint8)
    for row in range(4):
        for col in range(4):
            image[row * cell + 2 : (row + 1) * cell - 2, col * cell + 2 : (col + 1) * cell - 2] = (
                grid[row, col]
            )
    return image


def build() -> tuple[
    NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.uint8]
]:
    """Return vertices (V, 3), faces (F, 3), per-corner UVs (F, 3, 2) and the atlas image."""
    coords = [_axis_coordinates(h, RADIUS_MM) for h in HALF_MM]
    inner = HALF_MM - RADIUS_MM
    points, faces, uvs = [], [], []
    offset = 0
    # (normal axis, sign, u axis, v axis) for the six faces, u x v = outward normal.
    sides = [(2, 1, 0, 1), (2, -1, 1, 0), (0, 1, 1, 2), (0, -1, 2, 1), (1, 1, 2, 0), (1, -1, 0, 2)]
    for tile, (axis, sign, ua, va) in enumerate(sides):
        cu, cv = coords[ua], coords[va]
        grid_u, grid_v = np.meshgrid(cu, cv, indexing="xy")
        p = np.zeros((*grid_u.shape, 3))
        p[..., axis] = sign * HALF_MM[axis]
        p[..., ua] = grid_u
        p[..., va] = grid_v
        centre = np.clip(p, -inner, inner)
        direction = p - centre
        direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
        surface = centre + RADIUS_MM * direction
        nv, nu = grid_u.shape
        index = np.arange(nv * nu).reshape(nv, nu) + offset
        a, b = index[:-1, :-1], index[:-1, 1:]
        c, d = index[1:, 1:], index[1:, :-1]
        quads = np.stack([a, b, c, d], -1).reshape(-1, 4)
        faces.append(np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]))
        tu = (grid_u - cu[0]) / (cu[-1] - cu[0])
        tv = (grid_v - cv[0]) / (cv[-1] - cv[0])
        col, row = tile % 3, tile // 3
        uv = np.stack([(col + 0.02 + 0.96 * tu) / 3, 1 - (row + 0.98 - 0.96 * tv) / 2], -1)
        uvs.append(uv.reshape(-1, 2))
        points.append(surface.reshape(-1, 3))
        offset += nv * nu
    all_points = np.concatenate(points)
    all_faces = np.concatenate(faces)
    corner_uv = np.concatenate(uvs)[all_faces]
    # Merge the points shared by neighbouring faces (computed identically, so bit-equal).
    vertices, inverse = np.unique(np.round(all_points, 9), axis=0, return_inverse=True)
    merged = inverse.reshape(-1)[all_faces]
    atlas = np.concatenate(
        [np.concatenate([_tile(3 * r + c) for c in range(3)], axis=1) for r in range(2)], axis=0
    )
    return vertices, merged.astype(np.int64), corner_uv, atlas.astype(np.uint8)


def write(out: Path = OUT) -> None:
    """Write the OBJ, MTL and PNG into `out`."""
    vertices, faces, corner_uv, atlas = build()
    out.mkdir(parents=True, exist_ok=True)
    Image.fromarray(atlas).save(out / "colour_target.png", optimize=True)
    (out / "colour_target.mtl").write_text(
        "# shellvox default model: colour target\nnewmtl target\nKd 1 1 1\n"
        "map_Kd colour_target.png\n"
    )
    uv_rows, uv_index = np.unique(
        np.round(corner_uv.reshape(-1, 2), 6), axis=0, return_inverse=True
    )
    uv_index = uv_index.reshape(-1, 3)
    lines = [
        "# shellvox default model: 24 x 16 x 6 mm rounded colour target (mm)",
        "mtllib colour_target.mtl",
    ]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in uv_rows]
    lines.append("usemtl target")
    lines += [
        f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}"
        for (a, b, c), (ta, tb, tc) in zip(faces, uv_index, strict=True)
    ]
    (out / "colour_target.obj").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    write()
    print(f"wrote {OUT}")
