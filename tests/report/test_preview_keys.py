"""The previews carry a key, readable captions and sections that show every layer.

A synthetic build is written by hand (tifffile, a manifest dict): a block thick enough
for a core with two thin rods (along x and z) and a thin ear (along y) sticking out of
it, so that each axis's middle plane cuts only a rod or the ear (colour and backing, no
core), and the ear is the only vivid colour (a rule that looks for colour alone picks
it on y). The pictures are read back
with Pillow and checked against the volume and the manifest: the chosen planes hold
every layer the volume holds, every layer's and material's colour is a swatch in the
picture's key, and the captions' text is drawn at least 10 px tall.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile
from PIL import Image
from scipy import ndimage

from shellvox.report import write_previews
from shellvox.report._planes import CORE_SHARE, LayerCounts, choose_plane
from shellvox.voxel.io import BAND_RGB, CORE_RGB, FADE, OUTSIDE_RGB

SHAPE = (36, 40, 44)  # z, y, x
CORE = 3
LAYER_NAMES = ("outside", "skin", "backing", "core")
MATERIALS = {0: ("void", (0, 0, 0)), 1: ("cyan", (0, 89, 158)), 2: ("magenta", (161, 35, 99)),
             3: ("white", (220, 222, 216))}  # fmt: skip
SECTIONS = ("section_xy.png", "section_xz.png", "section_yz.png")


def _volume() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Layers, colour and materials of the block with two rods and an ear (see the module)."""
    inside = np.zeros(SHAPE, bool)
    inside[2:16, 2:16, 2:16] = True  # the block: 14 voxels across, a core inside
    inside[6:10, 6:10, 16:42] = True  # a rod along x, 4 x 4 voxels: two layers only
    inside[16:34, 6:10, 6:10] = True  # a rod along z
    ear = np.zeros(SHAPE, bool)
    ear[2:16, 16:38, 8:12] = True  # a plate along y, 4 voxels thin: two layers only
    depth = ndimage.distance_transform_edt(inside | ear)
    layers = np.select([depth > 2, depth > 1, depth > 0], [3, 2, 1], 0).astype(np.uint8)
    colour = np.full((*SHAPE, 3), 128, np.uint8)
    skin = layers == 1
    colour[skin & ear] = (230, 20, 20)  # only the ear is vivid
    colour[skin & ~ear & (np.indices(SHAPE)[2] < 9)] = (110, 110, 110)
    materials = np.where(layers > 1, 3, 0).astype(np.uint8)
    checker = np.indices(SHAPE).sum(axis=0) % 2 == 0
    materials[skin] = np.where(checker[skin], 1, 2)
    return layers, colour, materials


def _manifest() -> dict:
    layers = [{"index": 0, "name": "outside", "colour": False}]
    layers += [{"index": 1, "name": "skin", "colour": True, "thickness_mm": 0.1},
               {"index": 2, "name": "backing", "colour": False, "thickness_mm": 0.1},
               {"index": 3, "name": "core", "colour": False}]  # fmt: skip
    return {
        "grid": {
            "shape_zyx": list(SHAPE),
            "voxel_size_mm": [0.1, 0.1, 0.1],
            "origin_mm": [0.0, 0.0, 0.0],
        },
        "layers": layers,
        "files": {"layers.tif": {}, "colour.tif": {}, "materials.tif": {}},
        "materials": [
            {"index": i, "name": n, "display_srgb": list(c)} for i, (n, c) in MATERIALS.items()
        ],
    }


@pytest.fixture(scope="module")
def previews(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rods")
    layers, colour, materials = _volume()
    for name, volume in (("layers.tif", layers), ("colour.tif", colour),
                         ("materials.tif", materials)):  # fmt: skip
        tifffile.imwrite(folder / name, volume, compression="zlib")
    written = write_previews(folder, _manifest())
    return folder, layers, colour, {path.name: path for path in written}


def _read(path) -> tuple[np.ndarray, dict]:
    with Image.open(path) as image:
        return np.asarray(image.convert("RGB")), dict(image.text)


def _key_region(path) -> np.ndarray:
    pixels, text = _read(path)
    left, top, width, height = json.loads(text["shellvox:key"])
    return pixels[top : top + height, left : left + width]


def _count(pixels: np.ndarray, rgb) -> int:
    return int(np.all(pixels == np.asarray(rgb, np.uint8), axis=-1).sum())


def test_each_section_holds_every_layer_where_the_middle_plane_misses_the_core(previews):
    _, layers, colour, written = previews
    present = set(np.unique(layers).tolist())
    assert present == {0, 1, 2, 3}
    vivid_y = np.count_nonzero(np.ptp(colour.astype(int), axis=-1) > 24, axis=(0, 2))
    assert CORE not in layers[:, int(np.argmax(vivid_y))]  # nor does the most vivid plane
    for name in SECTIONS:
        _, text = _read(written[name])
        section = json.loads(text["shellvox:section"])
        axis, index = section["axis"], section["index"]
        plane = np.take(layers, index, axis="zyx".index(axis))
        middle = np.take(layers, SHAPE["zyx".index(axis)] // 2, axis="zyx".index(axis))
        assert CORE not in set(np.unique(middle).tolist())  # the case is what it claims
        assert set(np.unique(plane).tolist()) == present, (name, index)
        pixels, _ = _read(written[name])
        key_top = json.loads(text["shellvox:key"])[1]
        assert _count(pixels[:key_top], CORE_RGB) > 100  # the core is drawn, above the key


def _tones() -> tuple[list[tuple[int, int, int]], list[tuple[int, int, int]]]:
    tone = [OUTSIDE_RGB, BAND_RGB[0], BAND_RGB[1], CORE_RGB]
    faded = [tuple(round(v + (255 - v) * FADE) for v in t) for t in tone]
    return tone, faded


def test_section_keys_hold_each_layer_colour_as_drawn(previews):
    _, _, colour, written = previews
    tone, faded = _tones()
    voxel_colours = {tuple(c) for c in np.unique(colour.reshape(-1, 3), axis=0).tolist()}
    for name in SECTIONS:
        key = _key_region(written[name])
        pixels, _ = _read(written[name])
        for rgb in tone:  # the layers panel's tones
            assert _count(key, rgb) >= 12 * 12, (name, rgb)
            assert _count(pixels, rgb) > _count(key, rgb)  # and drawn in the panels
        for rgb in faded[2:]:  # the colour panel's lightened backing and core
            assert _count(key, rgb) >= 12 * 12, (name, rgb)
        # the key is apart from the panels: no voxel colour but its neutral swatches
        in_key = {tuple(c) for c in np.unique(key.reshape(-1, 3), axis=0).tolist()}
        vivid = {c for c in voxel_colours if max(c) - min(c) > 24}
        assert not in_key & vivid


def test_halftone_and_histogram_keys_hold_each_material_and_band(previews):
    _, _, _, written = previews
    halftone = next(path for name, path in written.items() if name.startswith("halftone_z"))
    key = _key_region(halftone)
    for index, (_, rgb) in MATERIALS.items():
        drawn = OUTSIDE_RGB if index == 0 else rgb  # void is drawn white
        assert _count(key, drawn) >= 12 * 12, (index, drawn)  # every material of the build
    key = _key_region(written["layer_depth_histogram.png"])
    for rgb in BAND_RGB[:2]:
        assert _count(key, rgb) >= 12 * 12


def _first_line_height(pixels: np.ndarray) -> int:
    """Rows of the first line of dark (text) pixels from the top."""
    dark = (pixels.max(axis=-1) < 100).any(axis=1)
    first = int(np.argmax(dark))
    return int(np.argmin(dark[first:]))


def test_captions_are_at_least_ten_pixels(previews):
    # each title holds parentheses, which span about 1.1 em: a 10 px font draws them 11 px
    _, _, _, written = previews
    for path in written.values():
        pixels, _ = _read(path)
        assert _first_line_height(pixels) >= 11, path.name


def test_pictures_have_tight_margins(previews):
    _, _, _, written = previews
    for name in (*SECTIONS, "outer_views.png"):
        pixels, _ = _read(written[name])
        drawn = np.argwhere((pixels != 255).any(axis=-1))
        top, left = drawn.min(axis=0)
        bottom, right = pixels.shape[:2] - drawn.max(axis=0) - 1
        assert max(top, left, bottom, right) <= 12, (name, top, left, bottom, right)


def test_layer_counts_match_each_plane():
    rng = np.random.default_rng(5)
    volume = rng.integers(0, 5, (7, 9, 11)).astype(np.uint8)
    counts = LayerCounts(volume.shape)
    for z, page in enumerate(volume):
        counts.add_page(z, page)
    for axis in "zyx":
        for index in range(volume.shape["zyx".index(axis)]):
            plane = np.take(volume, index, axis="zyx".index(axis))
            expected = np.bincount(plane.ravel(), minlength=256)
            assert counts.counts[axis][index].tolist() == expected.tolist()


def _slow_choice(volume: np.ndarray, axis: int, core: int, vivid: np.ndarray) -> int:
    """The rule of :func:`choose_plane`, plane by plane with Python sets."""
    planes = [np.take(volume, i, axis=axis) for i in range(volume.shape[axis])]
    present = set(np.unique(volume).tolist()) - {0}
    held = [len(set(np.unique(p).tolist()) & present) for p in planes]
    part = [i for i, p in enumerate(planes) if (p > 0).any()]
    centre = (part[0] + part[-1]) / 2
    best = [i for i in range(len(planes)) if held[i] == max(held)]
    cores = [int((p == core).sum()) for p in planes]
    most = max(cores[i] for i in best)
    best = [i for i in best if cores[i] >= CORE_SHARE * most]
    return min(best, key=lambda i: (-vivid[i], -cores[i], abs(i - centre)))


@pytest.mark.parametrize("seed", range(6))
def test_choice_matches_a_plane_by_plane_reference(seed):
    rng = np.random.default_rng(seed)
    inside = ndimage.binary_opening(rng.random((12, 14, 16)) < 0.7)
    depth = ndimage.distance_transform_edt(inside)
    volume = np.select([depth > 2, depth > 1, depth > 0], [3, 2, 1], 0).astype(np.uint8)
    counts = LayerCounts(volume.shape)
    for z, page in enumerate(volume):
        counts.add_page(z, page)
    for axis, name in enumerate("zyx"):
        vivid = rng.integers(0, 3, volume.shape[axis])
        chosen = choose_plane(counts.counts[name], CORE, vivid)
        assert chosen == _slow_choice(volume, axis, CORE, vivid), (seed, name)
