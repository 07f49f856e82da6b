"""The viewer page in real headless Chromium (Debian's, driven by Playwright).

Loads the page on a small build, moves the slider, switches every axis and mode, checks
the drawn pixels against the stacks (tifffile) and the manifest, clicks a voxel and
checks the read-out against the stacks, the manifest, colour-science and trimesh.
A screenshot of every mode is saved (path printed; ``SHELLVOX_TEST_ARTIFACTS=DIR`` keeps
them in DIR). Without ``/usr/bin/chromium`` (``apt-get install chromium``, which
scripts/bootstrap.sh does) the test skips, except under CI (``CI`` set), where it fails.
No browser is downloaded: Playwright drives the system binary.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import colour
import numpy as np
import pytest
import tifffile
import trimesh
from PIL import Image
from viewer_run import MODEL, expected_opening, serving, uniform_texture_colour

from shellvox.voxel.io import BAND_RGB, CORE_RGB, OUTSIDE_RGB

CHROMIUM = Path("/usr/bin/chromium")
ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
MODES = ("colour", "layers", "blend", "materials", "depth", "thickness")


def _missing(reason: str) -> None:
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI must run the browser test: scripts/bootstrap.sh installs it)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def playwright_api():
    if not CHROMIUM.is_file():
        _missing(f"{CHROMIUM} is missing: apt-get install chromium")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _missing("Playwright is not installed: pip install -r requirements.lock")
    with sync_playwright() as api:
        yield api


@pytest.fixture
def page(playwright_api, tmp_path):
    context = playwright_api.chromium.launch_persistent_context(
        str(tmp_path / "profile"),  # a fresh profile
        executable_path=str(CHROMIUM),
        headless=True,
        args=ARGS,
        viewport={"width": 1280, "height": 860},
        device_scale_factor=1,
    )
    page = context.new_page()
    problems: list[str] = []
    page.on("pageerror", lambda error: problems.append(f"page error: {error}"))
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
    yield page
    context.close()
    assert not problems, problems


@pytest.fixture
def served(small_colour_build):
    with serving(small_colour_build) as viewer:
        yield viewer


@pytest.fixture
def artifacts(tmp_path):
    folder = Path(os.environ.get("SHELLVOX_TEST_ARTIFACTS") or tmp_path / "screenshots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _wait_view(page, axis: str, index: int, mode: str) -> None:
    page.wait_for_function(
        "([view]) => document.body.dataset.status === 'ready'"
        " && document.body.dataset.view === view",
        arg=[f"{axis}:{index}:{mode}"],
        timeout=30_000,
    )


def _canvas_pixels(page) -> tuple[np.ndarray, dict[str, float]]:
    box = page.locator("#view").bounding_box()
    picture = Image.open(io.BytesIO(page.locator("#view").screenshot())).convert("RGB")
    return np.asarray(picture), box


def _pixel_at(page, pixels, box, iu, iv) -> np.ndarray:
    point = page.evaluate("([u, v]) => shellvoxView.voxelToClient(u, v)", [int(iu), int(iv)])
    return pixels[round(point["y"] - box["y"]), round(point["x"] - box["x"])]


def test_viewer_in_chromium(page, served, small_colour_build, artifacts):
    folder = small_colour_build
    manifest = json.loads((folder / "manifest.json").read_text())
    layers = tifffile.imread(folder / "layers.tif")
    rgb = tifffile.imread(folder / "colour.tif")[..., :3]
    materials = tifffile.imread(folder / "materials.tif")
    n_layers = len(manifest["layers"])
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    palette = {0: OUTSIDE_RGB, n_layers - 1: CORE_RGB}
    palette.update({k: BAND_RGB[(k - 1) % len(BAND_RGB)] for k in range(1, n_layers - 1)})
    display = {m["index"]: m["display_srgb"] for m in manifest["materials"]}
    display[0] = list(OUTSIDE_RGB)

    opening = expected_opening(folder)
    page.goto(served.url)
    _wait_view(page, "z", opening["z"], "colour")
    page.locator("#toggle3d").click()  # the slices alone, the whole width (voxels larger)
    page.wait_for_function("document.getElementById('stage3d').classList.contains('hidden')")

    # move the slider to a slice through the top face's colour patches, then one key step
    in_colour = np.isin(layers, colour_layers)
    top = int(np.nonzero(in_colour.any(axis=(1, 2)))[0].max()) - 2
    page.locator("#slice").fill(str(top - 1))
    _wait_view(page, "z", top - 1, "colour")
    page.locator("#view").focus()
    page.keyboard.press("ArrowRight")
    _wait_view(page, "z", top, "colour")
    assert page.locator("#slice-number").input_value() == str(top)

    shots = []
    rng = np.random.default_rng(2)
    for axis in ("z", "y", "x"):
        page.locator(f'button.axis[data-axis="{axis}"]').click()
        index = top if axis == "z" else opening[axis]
        for mode in MODES:
            page.locator(f'button.mode[data-mode="{mode}"]').click()
            _wait_view(page, axis, index, mode)
            path = artifacts / f"viewer_{axis}_{mode}.png"
            page.screenshot(path=str(path))
            shots.append(path)
            # the drawn colour at voxel centres, against the stacks and the manifest
            plane = (slice(None),) * "zyx".index(axis) + (index,)
            pixels, box = _canvas_pixels(page)
            v_count, u_count = layers[plane].shape
            samples = rng.integers(0, v_count, 40), rng.integers(0, u_count, 40)
            for iv, iu in zip(*samples, strict=True):
                layer = layers[plane][iv, iu]
                expected = {
                    "layers": palette[layer],
                    "materials": display[materials[plane][iv, iu]],
                    "colour": rgb[plane][iv, iu] if layer in colour_layers else None,
                }.get(mode)
                if expected is not None:
                    got = _pixel_at(page, pixels, box, iu, iv)
                    assert got.tolist() == list(expected), (axis, mode, iu, iv)
    for path in shots:
        print(f"screenshot: {path}")
    assert len(shots) == 18

    # click a colour-layer voxel of the z slice and read it out
    page.locator('button.axis[data-axis="z"]').click()
    page.locator('button.mode[data-mode="colour"]').click()
    _wait_view(page, "z", top, "colour")
    chroma = np.where(in_colour[top], np.ptp(rgb[top].astype(int), axis=-1), -1)
    y, x = (int(i) for i in np.unravel_index(np.argmax(chroma), chroma.shape))  # a vivid one
    point = page.evaluate("([u, v]) => shellvoxView.voxelToClient(u, v)", [x, y])
    page.mouse.click(point["x"], point["y"])
    page.wait_for_function(
        "([key]) => document.body.dataset.probe === key", arg=[f"{top},{y},{x}"], timeout=30_000
    )

    def value(cell: str):
        return json.loads(page.locator(f"#ro-{cell}").get_attribute("data-value"))

    grid = manifest["grid"]
    centre = np.asarray(grid["origin_mm"]) + np.array([x, y, top]) * grid["voxel_size_mm"]
    assert value("index") == [top, y, x]
    np.testing.assert_allclose(value("position"), centre, atol=1e-12)
    assert value("layer") == layers[top, y, x]
    assert manifest["layers"][layers[top, y, x]]["name"] in page.locator("#ro-layer").inner_text()
    assert value("srgb") == rgb[top, y, x].tolist()
    lab = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(rgb[top, y, x] / 255.0))
    np.testing.assert_allclose(value("lab"), lab, atol=0.05)  # see test_viewer_server
    assert value("material") == materials[top, y, x]
    name = next(m["name"] for m in manifest["materials"] if m["index"] == materials[top, y, x])
    assert name in page.locator("#ro-material").inner_text()
    mesh = trimesh.load(folder / "thickness.ply", process=False, force="mesh")
    _, distance, _ = trimesh.proximity.closest_point(mesh, centre[None])
    assert value("depth") == pytest.approx(float(distance[0]), abs=1e-6)
    path = artifacts / "viewer_readout.png"
    page.screenshot(path=str(path))
    print(f"screenshot: {path}")


def _ramp(stops, t):
    """The page's colour ramp (its stops, linearly between them) at ``t`` in [0, 1]."""
    stops = np.asarray(stops, float)
    x = np.clip(t, 0, 1) * (len(stops) - 1)
    i = np.minimum(len(stops) - 2, np.floor(x).astype(int))
    return stops[i] + (stops[i + 1] - stops[i]) * (x - i)[:, None]


def _inner_radius_px(corners):
    """Radius (px) of the circle inside each screen triangle ``(n, 3, 2)``."""
    a, b, c = (
        np.linalg.norm(corners[:, (k + 1) % 3] - corners[:, (k + 2) % 3], axis=1) for k in range(3)
    )
    u, v = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / 2
    return 2 * area / np.maximum(a + b + c, 1e-9)


def test_opening_slice_and_3d_surface_in_chromium(page, served, small_colour_build, artifacts):
    from shellvox.viewer import VIVID_SPAN

    folder = small_colour_build
    manifest = json.loads((folder / "manifest.json").read_text())
    layers = tifffile.imread(folder / "layers.tif")
    rgb = tifffile.imread(folder / "colour.tif")[..., :3]
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    opening = expected_opening(folder)

    # opens on the slice with the most vivid colour, and draws it in colour
    page.goto(served.url)
    _wait_view(page, "z", opening["z"], "colour")
    assert page.locator("#slice-number").input_value() == str(opening["z"])
    assert page.evaluate("document.body.dataset.opening") == ",".join(
        f"{a}:{opening[a]}" for a in "zyx"
    )
    pixels, box = _canvas_pixels(page)
    a, b = (
        page.evaluate("([u, v]) => shellvoxView.voxelToClient(u, v)", p) for p in ([0, 0], [1, 1])
    )
    voxel_px = abs(b["x"] - a["x"]) * abs(b["y"] - a["y"])
    vivid = np.isin(layers[opening["z"]], colour_layers) & (
        np.ptp(rgb[opening["z"]].astype(int), axis=-1) > VIVID_SPAN
    )
    drawn = np.count_nonzero(np.ptp(pixels.astype(int), axis=-1) > VIVID_SPAN)
    assert drawn > 0.5 * vivid.sum() * voxel_px > 1000

    # the surface in 3D: colour and depth, seen from the top and from the front
    page.wait_for_function("(document.body.dataset.surface || '').startsWith('colour:')")
    obj = trimesh.load(MODEL, process=False, force="mesh")
    ply = trimesh.load(folder / "thickness.ply", process=False, force="mesh")
    depth = np.asarray(ply.metadata["_ply_raw"]["face"]["data"]["thickness_1"])  # layer 1
    stops = page.evaluate("shellvoxView.RAMP")
    plane_z = manifest["grid"]["origin_mm"][2] + opening["z"] * manifest["grid"]["voxel_size_mm"][2]
    shots = []
    for view, towards in (("top", [0, 0, 1]), ("front", [0, -1, 0])):
        # faces turned to the camera, away from the section's cut line
        facing = ply.face_normals @ towards > 0.9999
        corners_z = ply.triangles[:, :, 2]
        clear = (corners_z.min(axis=1) > plane_z + 0.4) | (corners_z.max(axis=1) < plane_z - 0.4)
        faces = np.flatnonzero(facing & clear)
        for mode in ("colour", "depth"):
            page.locator(f'button.surface-view[data-view="{view}"]').click()
            page.locator(f'button.surface-mode[data-mode="{mode}"]').click()
            page.wait_for_function(
                "([key]) => (document.body.dataset.surface || '').startsWith(key)",
                arg=[f"{mode}:{view}:z:{opening['z']}"],
            )
            path = artifacts / f"surface_{view}_{mode}.png"
            page.screenshot(path=str(path))
            shots.append(path)
            box = page.locator("#view3d").bounding_box()
            picture = Image.open(io.BytesIO(page.locator("#view3d").screenshot())).convert("RGB")
            pixels = np.asarray(picture).astype(int)
            points = np.concatenate(
                [ply.triangles_center[faces], ply.triangles[faces].reshape(-1, 3)]
            )
            screen = page.evaluate(
                "(ps) => ps.map((p) => shellvoxSurface.project(p))", points.tolist()
            )
            screen = np.array([[p["x"] - box["x"], p["y"] - box["y"]] for p in screen])
            centre_px, corner_px = screen[: len(faces)], screen[len(faces) :].reshape(-1, 3, 2)
            big = _inner_radius_px(corner_px) >= 3  # the centre pixel well inside the face
            got = pixels[
                np.round(centre_px[:, 1]).astype(int), np.round(centre_px[:, 0]).astype(int)
            ]
            if mode == "colour":
                expected, uniform = uniform_texture_colour(obj, ply.triangles_center[faces], 0.5)
                keep = big & uniform
                tolerance = 4
            else:
                expected = _ramp(stops, depth[faces] / depth.max())
                keep = big
                tolerance = 2
            assert keep.sum() >= 15, (view, mode, keep.sum())
            error = np.abs(got[keep] - expected[keep]).max(axis=1)
            assert np.mean(error <= tolerance) >= 0.95, (view, mode, np.sort(error)[-10:])
    # the section plane is drawn: the cut line's colour appears in the turned view
    page.locator("#view3d").dblclick()
    page.wait_for_function("(document.body.dataset.surface || '').startsWith('depth:default')")
    pixels = np.asarray(Image.open(io.BytesIO(page.locator("#view3d").screenshot())).convert("RGB"))
    cut = np.all(np.abs(pixels.astype(int) - [237, 0, 92]) <= 3, axis=-1)
    assert cut.sum() > 200
    for path in shots:
        print(f"screenshot: {path}")
