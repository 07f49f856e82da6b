"""The viewer's opening slices and its 3D surface, against tifffile, trimesh and the texture.

- the chooser against a brute-force reading of its rule, and the opening slices of a
  real build against the stacks (tifffile);
- the surface sent to the page: on the model's surface (trimesh), each face with the
  colour-layer depth of the ``thickness.ply`` face it lies in, coloured as the model's
  texture where the texture is uniform around the face;
- decimation and subdivision for the browser;
- ``/api/opening`` and ``/api/surface`` over HTTP.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import trimesh
from viewer_run import MODEL, expected_opening, http_get, serving, uniform_texture_colour

from shellvox.viewer import MIDDLE, BuildFolder, Overview, choose_section
from shellvox.viewer._surface import browser_faces


def _brute_choice(vivid, inside):
    planes = [i for i, flag in enumerate(inside) if flag]
    if not planes:
        return len(vivid) // 2
    low, high = planes[0], planes[-1]
    margin = (1 - MIDDLE) / 2 * (high - low)
    middle = [i for i in range(len(vivid)) if low + margin - 1e-9 <= i <= high - margin + 1e-9]
    middle = middle or [(low + high) // 2]
    return min(middle, key=lambda i: (-vivid[i], abs(i - (low + high) / 2)))


def test_the_chooser_follows_its_rule():
    rng = np.random.default_rng(5)
    for _ in range(300):
        n = int(rng.integers(1, 40))
        vivid = rng.integers(0, 4, n).astype(np.int64)
        inside = np.zeros(n, bool)
        a, b = sorted(rng.integers(0, n, 2))
        inside[a : b + 1] = rng.random() > 0.1
        assert choose_section(vivid, inside) == _brute_choice(vivid, inside)


@pytest.fixture(scope="module")
def overview(small_colour_build):
    with BuildFolder.open(small_colour_build) as folder:
        result = Overview(folder)
        result.start()
        assert result.done.wait(120)
        yield result
        result.close()


def test_the_opening_slices_are_the_most_vivid(overview, small_colour_build):
    assert overview.error is None
    assert overview.opening == expected_opening(small_colour_build)


def test_the_surface_lies_on_the_model_with_its_faces_depth_and_colour(
    overview, small_colour_build
):
    surface = overview.surface
    ply = trimesh.load(small_colour_build / "thickness.ply", process=False, force="mesh")
    data = ply.metadata["_ply_raw"]["face"]["data"]
    depth = np.asarray(data["thickness_1"])  # the colour layer is layer 1
    rng = np.random.default_rng(0)
    some = rng.choice(len(surface.depth_mm), min(3000, len(surface.depth_mm)), replace=False)
    triangles = surface.triangles_mm[some].astype(np.float64)
    centres = triangles.mean(axis=1)
    _, distance, nearest = trimesh.proximity.closest_point(ply, centres)
    assert distance.max() < 1e-4
    np.testing.assert_allclose(surface.depth_mm[some], depth[nearest], rtol=1e-6)
    # faces turned outwards: their normals point away from the model's centre, mostly
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert np.mean(np.einsum("ij,ij->i", normals, centres - ply.centroid) > 0) > 0.95
    obj = trimesh.load(MODEL, process=False, force="mesh")
    pick = some[:600]
    colour, uniform = uniform_texture_colour(obj, centres[:600], radius_mm=0.5)
    assert uniform.sum() > 80
    error = np.abs(surface.srgb[pick][uniform].astype(int) - colour[uniform]).max(axis=1)
    assert np.mean(error <= 3) > 0.97, np.sort(error)[-20:]


def _sphere(subdivisions):
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(sphere.vertices), np.asarray(sphere.faces, np.int64)


def test_a_large_surface_is_decimated_and_a_coarse_one_split():
    vertices, faces = _sphere(5)  # 20,480 faces
    new_vertices, new_faces, source = browser_faces(vertices, faces, edge_mm=1.0, max_faces=3000)
    assert 1000 < len(new_faces) <= 3000
    assert source.min() >= 0 and source.max() < len(faces)
    decimated = trimesh.Trimesh(new_vertices, new_faces, process=False)
    assert abs(decimated.volume - trimesh.Trimesh(vertices, faces).volume) < 0.05
    vertices, faces = _sphere(1)  # 80 faces, edges about 0.6
    new_vertices, new_faces, source = browser_faces(vertices, faces, edge_mm=0.1, max_faces=10**5)
    finer = trimesh.Trimesh(new_vertices, new_faces, process=False)
    assert finer.edges_unique_length.max() <= 0.1 + 1e-12
    # every new face inside its source face: its centre's barycentric weights are >= 0
    weights = trimesh.triangles.points_to_barycentric(
        vertices[faces[source]], finer.triangles_center
    )
    assert weights.min() > -1e-9
    assert np.array_equal(np.unique(source), np.arange(len(faces)))


def test_opening_and_surface_over_http(small_colour_build, tmp_path):
    with serving(small_colour_build) as server:
        status, _, body = http_get(server, "/api/opening?wait=30")
        answer = json.loads(body)
        assert status == 200 and answer["ready"]
        assert answer["slices"] == expected_opening(small_colour_build)
        status, headers, body = http_get(server, "/api/surface")
        assert status == 200
        n = int(headers["X-Faces"])
        assert len(body) == 43 * n
        corners = np.frombuffer(body, "<f4", 9 * n).reshape(n, 3, 3)
        depth = np.frombuffer(body, "<f4", n, offset=36 * n)
        assert float(headers["X-Depth-Range"].split(",")[1]) == pytest.approx(depth.max())
        mesh = trimesh.load(small_colour_build / "thickness.ply", process=False, force="mesh")
        assert np.all(corners.min(axis=(0, 1)) >= mesh.bounds[0] - 1e-4)
        assert np.all(corners.max(axis=(0, 1)) <= mesh.bounds[1] + 1e-4)
        for query in ("wait=31", "wait=x", "wait=1&wait=2"):
            assert http_get(server, f"/api/opening?{query}")[0] == 400
    # a build without thickness.ply (made with --thickness) has no surface to show
    folder = tmp_path / "build"
    shutil.copytree(small_colour_build, folder)
    manifest = json.loads((folder / "manifest.json").read_text())
    del manifest["files"]["thickness.ply"]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    (folder / "thickness.ply").unlink()
    with serving(folder) as server:
        status, _, body = http_get(server, "/api/surface")
        assert status == 404 and b"thickness.ply" in body
        status, _, body = http_get(server, "/api/opening?wait=30")
        assert json.loads(body)["slices"] == expected_opening(folder)
