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
from viewer_run import serving

from voxel.io import BAND_RGB, CORE_RGB, OUTSIDE_RGB

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
    n_z = layers.shape[0]

    page.goto(served.url)
    _wait_view(page, "z", n_z // 2, "colour")

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
        index = top if axis == "z" else layers.shape["zyx".index(axis)] // 2
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
