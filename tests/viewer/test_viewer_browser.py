"""The viewer page in real headless Chromium (Debian's, driven by Playwright).

Loads the page on a small build, moves the slider, switches every axis and mode, checks
the drawn pixels against the stacks (tifffile) and the manifest, clicks a voxel and
checks the read-out against the stacks, the manifest, colour-science and trimesh. The 3D
view's modes are checked against the model's texture, thickness.ply and proof.ply (the
soft proof, interpolated by brute force from trimesh's reading of it); its ΔE mode against
the soft-proof picture's steps (``DE_STEPS``, ``DE_RGB`` of :mod:`shellvox.voxel.io`).
A screenshot of every mode is saved (path printed; ``SHELLVOX_TEST_ARTIFACTS=DIR`` keeps
them in DIR). Without ``/usr/bin/chromium`` (``apt-get install chromium``, which
scripts/bootstrap.sh does) the test skips, except under CI (``CI`` set), where it fails.
No browser is downloaded: Playwright drives the system binary.
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import colour
import numpy as np
import pytest
import tifffile
import trimesh
from PIL import Image
from viewer_run import (
    MODEL,
    expected_opening,
    lab_to_srgb8,
    proof_reference,
    serving,
    uniform_texture_colour,
)

from shellvox.voxel.io import (
    BAND_RGB,
    CORE_RGB,
    DE_RGB,
    DE_STEPS,
    HATCH_RGB,
    NO_PREDICTION_RGB,
    OUTSIDE_RGB,
)

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


def _de_step(de):
    """The soft-proof picture's step of each error ``(n,)``: how many upper bounds it reaches.

    ``DE_STEPS`` are the steps' lower bounds (the last step open), so a step's upper bound
    is the next one's lower bound; NaN reaches none (step 0, drawn as no prediction).
    """
    de = np.asarray(de, float)
    return np.sum(de[:, None] >= np.asarray(DE_STEPS)[None, 1:], axis=1)


def _near_a_bound(de, margin=0.02):
    """Whether each error ``(n,)`` lies within `margin` of a bound between two steps.

    There the page's float32 interpolation and this brute force in float64 can fall on
    either side.
    """
    distance = np.abs(np.asarray(de, float)[:, None] - np.asarray(DE_STEPS)[None, 1:])
    return np.min(distance, axis=1) < margin


def _mix(pixels, colour, other, tolerance=4):
    """Whether each pixel is a mix of `colour` and `other`, and the share of `other` in it.

    ``pixels`` ``(..., 3)``; `colour` broadcast to it, `other` ``(3,)``; sRGB codes.
    """
    direction = other - colour
    share = np.sum((pixels - colour) * direction, axis=-1) / np.maximum(
        np.sum(direction**2, axis=-1), 1e-9
    )
    share = np.clip(share, 0, 1)
    residual = np.abs(pixels - (colour + share[..., None] * direction)).max(axis=-1)
    return residual <= tolerance, share


def _window(pixels, centres_px, rows=1, columns=4):
    """The pixels ``(n, 2 rows + 1, 2 columns + 1, 3)`` around each centre ``(n, 2)``."""
    y = np.round(centres_px[:, 1]).astype(int)[:, None] + np.arange(-rows, rows + 1)
    x = np.round(centres_px[:, 0]).astype(int)[:, None] + np.arange(-columns, columns + 1)
    return pixels[y[:, :, None], x[:, None, :]]


def _clearance_px(corners):
    """Distance (px) from each screen triangle's centroid ``(n, 3, 2)`` to its nearest side."""
    u, v = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / 2
    longest = np.max(
        [np.linalg.norm(corners[:, k] - corners[:, (k + 1) % 3], axis=1) for k in range(3)], axis=0
    )
    return 2 * area / (3 * np.maximum(longest, 1e-9))


def test_predicted_and_delta_e_on_the_3d_surface_in_chromium(
    page, served, small_colour_build, artifacts, tmp_path
):
    folder = small_colour_build
    manifest = json.loads((folder / "manifest.json").read_text())
    record = manifest["proof"]
    page.goto(served.url)
    page.wait_for_function("document.body.dataset.proof === 'ready'", timeout=60_000)
    for mode in ("predicted", "de"):
        assert page.locator(f'button.surface-mode[data-mode="{mode}"]').is_enabled()
    page.locator("#show-plane").uncheck()  # the faces alone, no section drawn over them
    # the page's scale is the picture's, as the server sent it
    scale = page.evaluate("shellvoxSurface.view.scale")
    assert [step["low"] for step in scale["steps"]] == list(DE_STEPS)
    assert [step["srgb"] for step in scale["steps"]] == DE_RGB.tolist()
    assert scale["no_prediction_srgb"] == list(NO_PREDICTION_RGB)
    assert scale["hatch_srgb"] == list(HATCH_RGB)
    period = scale["hatch_period_px"]
    hatch = np.array(HATCH_RGB)

    surface = served.overview.surface
    triangles = surface.triangles_mm.astype(np.float64)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    centres = triangles.mean(axis=1)
    canvas = page.locator("#view3d")
    shots = []
    checked = {"predicted": 0, "in": 0, "out": 0, "shaded": 0, "steps": set()}
    for view in ("top", "front", "default"):  # default: turned, most faces shaded
        if view == "default":
            canvas.dblclick()
        else:
            page.locator(f'button.surface-view[data-view="{view}"]').click()
        box = canvas.bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.wheel(0, -1100)  # 5 times closer: faces hold a window of pixels
        # faces turned to the camera (unshaded) and turned partly away (shaded): lit by a
        # light at the camera, each colour times 0.35 + 0.65 |cos| of the face's angle to it
        azimuth, elevation = np.radians(
            page.evaluate("[shellvoxSurface.view.azimuth, shellvoxSurface.view.elevation]")
        )
        towards = [
            np.cos(elevation) * np.cos(azimuth),
            np.cos(elevation) * np.sin(azimuth),
            np.sin(elevation),
        ]
        facing = normals @ towards
        faces = np.flatnonzero(facing > 0.5)
        shade = 0.35 + 0.65 * np.abs(facing[faces])
        for mode in ("predicted", "de"):
            page.locator(f'button.surface-mode[data-mode="{mode}"]').click()
            page.wait_for_function(
                "([key]) => (document.body.dataset.surface || '').startsWith(key)",
                arg=[f"{mode}:{view}:"],
            )
            page.evaluate(
                "new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"
            )
            path = artifacts / f"surface_{view}_{mode}.png"
            page.screenshot(path=str(path))
            shots.append(path)
            legend = page.locator("#surface-legend").inner_text()
            optics = page.locator("#surface-optics")
            assert optics.get_attribute("data-optics") == record["optics"]
            assert f"{record['optics']} optics" in optics.inner_text()
            pixels = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGB"))
            pixels = pixels.astype(int)
            points = np.concatenate([centres[faces], triangles[faces].reshape(-1, 3)])
            screen = page.evaluate(
                "(ps) => ps.map((p) => shellvoxSurface.project(p))", points.tolist()
            )
            screen = np.array([[p["x"] - box["x"], p["y"] - box["y"]] for p in screen])
            centre_px, corner_px = screen[: len(faces)], screen[len(faces) :].reshape(-1, 3, 2)
            # whole windows of pixels inside the face, the canvas, and clear of the overlays
            keep = _clearance_px(corner_px) >= 6
            keep &= np.all(
                (centre_px >= 8) & (centre_px < [box["width"] - 8, box["height"] - 8]), 1
            )
            for overlay in ("#stage3d .toolbar", "#surface-legend"):
                o = page.locator(overlay).bounding_box()
                low = np.array([o["x"] - box["x"] - 8, o["y"] - box["y"] - 8])
                high = low + np.array([o["width"], o["height"]]) + 16
                keep &= ~np.all((centre_px >= low) & (centre_px <= high), axis=1)
            truth = proof_reference(
                folder / "proof.ply",
                centres[faces[keep]],
                normals[faces[keep]],
                record["interpolation"],
            )
            # the error's steps are lit lightly: 0.8 + 0.2 |cos|
            lit = shade if mode == "predicted" else 0.8 + 0.2 * np.abs(facing[faces])
            lit = lit[keep][:, None]
            window = _window(pixels, centre_px[keep])  # (n, 3, 9, 3)
            if mode == "predicted":
                assert "predicted from the voxels" in legend
                srgb = lab_to_srgb8(truth["predicted_lab"], truth["white_xy"])
                expected = srgb * lit
                error = np.abs(window - expected[:, None, None]).max(axis=(1, 2, 3))
                assert np.mean(error <= 4) >= 0.95, (view, np.sort(error)[-10:])
                # the predicted colour is not the model's: the mode shows something else
                differs = np.abs(srgb - surface.srgb[faces[keep]]).max(axis=1) > 12
                assert differs.mean() > 0.3, (view, differs.mean())
                checked["predicted"] += int(keep.sum())
                continue
            assert "out of gamut" in legend and "CIEDE2000" in legend
            de = truth["total_de"]
            out = truth["gamut_de"] > record["in_gamut_de"]
            step = _de_step(np.nan_to_num(de))
            unlit = np.where(np.isnan(de)[:, None], NO_PREDICTION_RGB, DE_RGB[step])
            expected = unlit * lit
            # each pixel a mix of the step's colour (lit) and the hatching's (unlit; a line
            # can fall across pixels of the screenshot): its share of the hatching's colour
            mixed, share = _mix(window, expected[:, None, None], hatch)  # (n, 3, 9)
            hatched = share.mean(axis=(1, 2))
            # in gamut: the step's colour throughout; out: hatched as the picture, one pixel
            # of every `period` along each row
            good = np.all(mixed, axis=(1, 2)) & np.where(
                out, np.abs(hatched - 1 / period) <= 0.08, hatched <= 0.02
            )
            good |= _near_a_bound(de)
            for kind in (out, ~out):  # the counts of each are checked below
                assert np.all(good[kind]) or np.mean(good[kind]) >= 0.95, (view, hatched[kind])
            # and back: the pixels clear of the hatching, read on the picture's steps (lit
            # as the face), give the stored ΔE's step
            clear = share < 0.02
            colours = DE_RGB[None].astype(float) * lit[:, :, None]  # (n, 6, 3)
            known = ~np.isnan(de) & clear.any(axis=(1, 2))
            first = np.argmax(clear.reshape(len(de), -1), axis=1)
            pixel = window.reshape(len(de), -1, 3)[np.arange(len(de)), first]
            read = np.argmin(np.abs(pixel[:, None] - colours).sum(axis=-1), axis=1)
            right = (read == step) | (_near_a_bound(de) & (np.abs(read - step) <= 1))
            assert np.all(right[known]) or np.mean(right[known]) >= 0.95, (
                view,
                np.column_stack([de, read, step])[known & ~right][:10],
            )
            print(f"{view}: {(~out).sum()} faces in gamut, {out.sum()} out")
            checked["in"] += int((~out).sum())
            checked["out"] += int(out.sum())
            checked["shaded"] += int(np.sum(shade[keep] < 0.95))
            checked["steps"].update(step[known & right].tolist())

    # the legend: the picture's six steps, with its labels and colours, no prediction's
    # grey and the hatching's swatch drawn by the picture's rule
    labels = page.locator("#de-scale .step").all_inner_texts()
    assert [label.strip() for label in labels] == ["0-1", "1-2", "2-3", "3-5", "5-10", ">= 10"]
    swatches = page.evaluate(
        "[...document.querySelectorAll('#de-scale .step .swatch, #de-none .swatch')]"
        ".map((e) => getComputedStyle(e).backgroundColor)"
    )
    rgb = [*DE_RGB.tolist(), list(NO_PREDICTION_RGB)]
    assert swatches == [f"rgb({r}, {g}, {b})" for r, g, b in rgb]
    hatch_swatch = np.array(
        page.evaluate(
            "(() => { const c = document.querySelector('#de-hatched canvas');"
            " return [...c.getContext('2d').getImageData(0, 0, c.width, c.height).data]; })()"
        )
    ).reshape(12, 12, 4)[..., :3]
    rows, columns = np.indices((12, 12))
    lines = (rows + columns) % period == 0
    assert (hatch_swatch[lines] == HATCH_RGB).all() and (hatch_swatch[~lines] == DE_RGB[0]).all()
    assert "out of gamut" in page.locator("#de-hatched").inner_text()
    assert checked["predicted"] >= 60 and checked["in"] >= 20 and checked["out"] >= 20, checked
    assert checked["shaded"] >= 20 and len(checked["steps"]) >= 3, checked

    # a build without a soft proof: the two modes stay off, and say why
    without = tmp_path / "without"
    shutil.copytree(folder, without)
    manifest = json.loads((without / "manifest.json").read_text())
    del manifest["files"]["proof.ply"], manifest["proof"]
    (without / "manifest.json").write_text(json.dumps(manifest))
    (without / "proof.ply").unlink()
    with serving(without) as other:
        page.goto(other.url)
        page.wait_for_function("document.body.dataset.proof === 'none'", timeout=60_000)
        for mode in ("predicted", "de"):
            button = page.locator(f'button.surface-mode[data-mode="{mode}"]')
            assert button.is_disabled()
            assert "proof.ply" in button.get_attribute("title")
        assert "no soft proof" in page.locator("#surface-status").inner_text()
        path = artifacts / "surface_no_proof.png"
        page.screenshot(path=str(path))
        shots.append(path)
    for path in shots:
        print(f"screenshot: {path}")
