"""``inspect``'s previews show the model's colours: every colour they draw is a voxel's.

The test reads the pictures back with Pillow and the stacks with tifffile. The
pictures' own tones (outside, the layer tones, their lightened versions under the
colour, the inset's box, the captions' greys) are set aside; what remains must be
colours of colour-layer voxels in colour.tif, and there must be many of them.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import tifffile
from PIL import Image

from shellvox.cli import main
from shellvox.voxel.io import BAND_RGB, CORE_RGB, FADE, OUTSIDE_RGB

SECTIONS = ("section_xy.png", "section_xz.png", "section_yz.png")


def _drawn_colours(path) -> set[tuple[int, int, int]]:
    """Distinct colours of a picture, without its own tones and neutral (caption) greys."""
    tones = np.array([OUTSIDE_RGB, *BAND_RGB, CORE_RGB, (255, 0, 255)], dtype=float)
    faded = np.round(tones + (255 - tones) * FADE)
    own = {tuple(int(v) for v in c) for c in np.concatenate([tones, faded])}
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    colours = {tuple(int(v) for v in c) for c in np.unique(pixels, axis=0)}
    return {c for c in colours - own if max(c) != min(c)}


def _voxel_colours(folder, manifest_layers) -> set[tuple[int, int, int]]:
    layers = tifffile.imread(folder / "layers.tif")
    colour = tifffile.imread(folder / "colour.tif")[..., :3]
    coloured = np.isin(layers, [layer["index"] for layer in manifest_layers if layer["colour"]])
    return {tuple(int(v) for v in c) for c in np.unique(colour[coloured], axis=0)}


def _inspect(build, tmp_path, capsys):
    import json

    folder = tmp_path / "build"
    shutil.copytree(build, folder)
    assert main(["inspect", str(folder)]) == 0
    printed = capsys.readouterr().out
    manifest = json.loads((folder / "manifest.json").read_text())
    return folder, printed, _voxel_colours(folder, manifest["layers"])


def test_sections_and_outer_views_show_the_colours(small_colour_build, tmp_path, capsys):
    folder, printed, voxel_colours = _inspect(small_colour_build, tmp_path, capsys)
    for name in (*SECTIONS, "outer_views.png", "layer_depth_histogram.png"):
        assert str(folder / "preview" / name) in printed
    in_sections: set[tuple[int, int, int]] = set()
    for name in SECTIONS:
        drawn = _drawn_colours(folder / "preview" / name)
        assert drawn <= voxel_colours, drawn - voxel_colours  # nothing but voxel colours
        in_sections |= drawn
    assert len(in_sections) >= 20
    outer = _drawn_colours(folder / "preview" / "outer_views.png")
    assert outer <= voxel_colours
    assert len(outer) >= 20


@pytest.mark.slow
def test_demo_previews_show_the_colours(tmp_path, capsys):
    # what `make demo` does: the default model on the J750 grid, then inspect
    from pathlib import Path

    model = Path(__file__).resolve().parents[2] / "data" / "colour_target" / "colour_target.obj"
    out = tmp_path / "demo"
    argv = ["build", str(model), "-o", str(out), "--printer", "j750", "--no-progress"]
    assert main(argv) == 0
    folder, _, voxel_colours = _inspect(out, tmp_path / "copy", capsys)
    drawn = set().union(*(_drawn_colours(folder / "preview" / name) for name in SECTIONS))
    assert drawn <= voxel_colours
    assert len(drawn) >= 20
