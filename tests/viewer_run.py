"""Run the viewer's server on a build in a thread, for the viewer's tests."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from shellvox.viewer import BuildFolder, ViewerServer

#: The default model (a textured OBJ).
MODEL = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"


@contextmanager
def serving(build: Path) -> Iterator[ViewerServer]:
    """Yield a :class:`ViewerServer` of `build` on a free port, stopped on exit."""
    viewer = ViewerServer(BuildFolder.open(build), 0)
    thread = threading.Thread(target=viewer.serve_forever, daemon=True)
    thread.start()
    try:
        yield viewer
    finally:
        viewer.shutdown()
        viewer.server_close()
        thread.join()


def expected_opening(build: Path) -> dict[str, int]:
    """The opening slices of `build`, recomputed from the stacks (tifffile) and the rule.

    The rule of ``shellvox inspect``'s sections and ``shellvox view``'s opening slice:
    on each axis, among the planes crossing the middle 60 % of the part's extent, the one
    with the most colour-layer voxels whose sRGB channels span more than 24 (ties: the
    one nearest the part's centre). Whole arrays here, page by page in the package.
    """
    import json

    import numpy as np
    import tifffile

    manifest = json.loads((build / "manifest.json").read_text())
    layers = tifffile.imread(build / "layers.tif")
    rgb = tifffile.imread(build / "colour.tif")[..., :3].astype(int)
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    vivid = np.isin(layers, colour_layers) & (rgb.max(axis=-1) - rgb.min(axis=-1) > 24)
    chosen = {}
    for position, axis in enumerate("zyx"):
        others = tuple(a for a in range(3) if a != position)
        counts = vivid.sum(axis=others)
        planes = np.flatnonzero((layers > 0).any(axis=others))
        low, high = planes.min(), planes.max()
        margin = 0.2 * (high - low)
        candidates = [i for i in range(low, high + 1) if low + margin <= i <= high - margin]
        candidates = candidates or [(low + high) // 2]
        chosen[axis] = int(min(candidates, key=lambda i: (-counts[i], abs(i - (low + high) / 2))))
    return chosen


def _texture_colour(mesh, points, faces):
    """The texture's sRGB at `points` on `faces` of the textured OBJ (nearest texel)."""
    import numpy as np
    import trimesh

    corners = mesh.triangles[faces]
    weights = trimesh.triangles.points_to_barycentric(corners, points)
    uv = np.einsum("nk,nkj->nj", weights, mesh.visual.uv[mesh.faces[faces]])
    image = np.asarray(mesh.visual.material.image.convert("RGB"))
    h, w = image.shape[:2]
    x = np.clip(np.floor(uv[:, 0] % 1 * w), 0, w - 1).astype(int)
    y = np.clip(np.floor((1 - uv[:, 1] % 1) * h), 0, h - 1).astype(int)
    return image[y, x].astype(int)


def uniform_texture_colour(mesh, points, radius_mm):
    """The texture colour at surface points, and whether it is the same within `radius_mm`.

    ``mesh`` is the model as trimesh loads it (UVs and the texture image); points
    ``(N, 3)`` mm on it. Returns ``(N, 3)`` int sRGB and ``(N,)`` bool.
    """
    import numpy as np
    import trimesh

    _, _, faces = trimesh.proximity.closest_point(mesh, points)
    centre = _texture_colour(mesh, points, faces)
    same = np.ones(len(points), bool)
    for angle in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        offset = radius_mm * np.array([np.cos(angle), np.sin(angle), 0.0])
        for direction in (offset, offset[[2, 0, 1]], offset[[0, 2, 1]]):
            near, _, near_faces = trimesh.proximity.closest_point(mesh, points + direction)
            around = _texture_colour(mesh, near, near_faces)
            same &= np.abs(around - centre).max(axis=1) <= 2
    return centre, same
