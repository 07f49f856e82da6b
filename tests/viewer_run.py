"""Run the viewer's server on a build in a thread, for the viewer's tests."""

from __future__ import annotations

import http.client
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from shellvox.viewer import BuildFolder, ViewerServer

#: The default model (a textured OBJ).
MODEL = Path(__file__).resolve().parents[1] / "data" / "colour_target" / "colour_target.obj"


def http_get(server: ViewerServer, path: str) -> tuple[int, dict[str, str], bytes]:
    """GET `path` from a serving viewer: status, headers and body."""
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=60)
    connection.request("GET", path)
    response = connection.getresponse()
    body = response.read()
    connection.close()
    return response.status, dict(response.getheaders()), body


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


def proof_reference(proof_ply, points, normals, interpolation):
    """The soft proof at surface points, brute force from ``proof.ply`` as trimesh reads it.

    Follows the rule the manifest's ``proof["interpolation"]`` record states
    (`interpolation`: ``neighbours``, ``reach_spacings``, ``same_side_dot``, ``weight``):
    of the ``neighbours`` samples nearest a point (all distances computed), those within
    ``reach_spacings`` mean spacings (the header's ``spacing_mm``) whose normals face the
    point's side, weighted as ``weight`` says (``exp(-(distance / mean_spacing_mm)^2)``,
    or ``1 / distance^2`` with distances below 1e-6 mm as 1e-6); NaN where none.
    ``points`` and ``normals`` ``(M, 3)``; returns a dict of ``predicted_lab`` ``(M, 3)``,
    ``total_de`` and ``gamut_de`` ``(M,)`` float64, and the header's ``white_xy`` and
    ``optics``.
    """
    import numpy as np
    import trimesh

    cloud = trimesh.load(proof_ply)
    raw = cloud.metadata["_ply_raw"]["vertex"]["data"]
    header = Path(proof_ply).read_bytes().split(b"end_header\n")[0].decode("ascii")
    comments = dict(
        line.split(" ", 2)[1:] for line in header.splitlines() if line.startswith("comment ")
    )
    spacing = float(comments["spacing_mm"])
    samples = np.asarray(cloud.vertices, float)
    sample_normals = np.column_stack([raw[n] for n in ("nx", "ny", "nz")]).astype(float)
    values = {
        "predicted_lab": np.column_stack([raw[f"predicted_{c}"] for c in "Lab"]).astype(float),
        "total_de": np.asarray(raw["total_de"], float),
        "gamut_de": np.asarray(raw["gamut_de"], float),
    }
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    k = int(interpolation["neighbours"])
    rule = interpolation["weight"]
    if rule.startswith("exp(-(distance / mean_spacing_mm)^2)"):

        def weigh(d):
            return np.exp(-((d / spacing) ** 2))

    elif rule.startswith("1 / distance^2"):

        def weigh(d):
            return 1.0 / np.maximum(d, 1e-6) ** 2

    else:
        raise ValueError(f"the manifest's proof weight {rule!r} is not one this reference knows")
    out = {name: np.full((len(points), *v.shape[1:]), np.nan) for name, v in values.items()}
    for start in range(0, len(points), 256):
        chunk = slice(start, start + 256)
        distance = np.linalg.norm(points[chunk, None] - samples[None], axis=-1)  # (m, N)
        nearest = np.argsort(distance, axis=1)[:, :k]
        d = np.take_along_axis(distance, nearest, axis=1)
        facing = np.einsum("mkc,mc->mk", sample_normals[nearest], normals[chunk])
        use = (d <= interpolation["reach_spacings"] * spacing) & (
            facing > interpolation["same_side_dot"]
        )
        weight = np.where(use, weigh(d), 0.0)
        for name, value in values.items():
            v = value[nearest]  # (m, k) or (m, k, 3)
            w = weight if v.ndim == 2 else weight[..., None]
            w = np.where(np.isfinite(v), w, 0.0)
            total = w.sum(axis=1)
            mean = (w * np.nan_to_num(v)).sum(axis=1) / np.where(total > 0, total, 1.0)
            out[name][chunk] = np.where(total > 0, mean, np.nan)
    white = np.array([float(v) for v in comments["white_xy"].split(",")])
    return {**out, "white_xy": white, "optics": comments["optics"]}


def lab_to_srgb8(lab, white_xy):
    """8-bit sRGB of CIELAB relative to `white_xy` (colour-science: Bradford to D65, sRGB).

    ``(M, 3)`` in, ``(M, 3)`` int out; grey 160 where the CIELAB is NaN.
    """
    import colour
    import numpy as np

    lab = np.asarray(lab, float)
    known = np.all(np.isfinite(lab), axis=1)
    out = np.full(lab.shape, 160, int)
    xyz = colour.Lab_to_XYZ(lab[known], white_xy)
    rgb = colour.XYZ_to_RGB(
        xyz, "sRGB", illuminant=white_xy, chromatic_adaptation_transform="Bradford",
        apply_cctf_encoding=True,
    )  # fmt: skip
    out[known] = np.rint(np.clip(rgb, 0, 1) * 255).astype(int)
    return out
