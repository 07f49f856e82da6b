"""A tray of three models (texture, vertex and face colours) against each model built alone.

Independent truth: each model's own build, read back by tifffile; the tray's tiles must
equal them byte for byte and the rest of the tray must be void. The layout is checked on
the voxels themselves: the connected parts of the tray's layers (scikit-image), one per
model, stay in the printer's tray and keep the gap.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import tifffile
from skimage.measure import label, regionprops
from tray_models import tray_models

from shellvox.cli import main
from shellvox.viewer import BuildFolder, probe

OPTIONS = ["--voxel-size", "0.3,0.3,0.25", "--format", "tiff", "--no-materials", "--no-progress"]
GAP_MM = 4.0
J750_TRAY_MM = (490.0, 390.0, 200.0)


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """The tray of the three models, and each model built alone (same options)."""
    folder = tmp_path_factory.mktemp("tray")
    models = tray_models(folder)
    tray = folder / "tray"
    argv = ["build", *map(str, models), "-o", str(tray), "--gap", str(GAP_MM), *OPTIONS]
    assert main(argv) == 0
    alone = []
    for index, model in enumerate(models):
        out = folder / f"alone_{index}"
        assert main(["build", str(model), "-o", str(out), *OPTIONS]) == 0
        alone.append(out)
    return tray, alone


def _stacks(out: Path) -> tuple[np.ndarray, np.ndarray]:
    return tifffile.imread(out / "layers.tif"), tifffile.imread(out / "colour.tif")


def test_tiles_equal_each_model_built_alone(builds):
    tray, alone = builds
    layers, colour = _stacks(tray)
    manifest = json.loads((tray / "manifest.json").read_text())
    entries = manifest["tray"]["models"]
    assert len(entries) == 3
    covered = np.zeros(layers.shape, dtype=bool)
    for entry, single in zip(entries, alone, strict=True):
        single_layers, single_colour = _stacks(single)
        single_manifest = json.loads((single / "manifest.json").read_text())
        assert entry["grid_shape_zyx"] == single_manifest["grid"]["shape_zyx"]
        z, y, x = entry["grid_offset_zyx"]
        dz, dy, dx = single_layers.shape
        tile = (slice(z, z + dz), slice(y, y + dy), slice(x, x + dx))
        assert np.array_equal(layers[tile], single_layers)
        assert np.array_equal(colour[tile], single_colour)
        assert single_layers.max() == 3  # the tile holds a whole part, down to its core
        covered[tile] = True
    assert not layers[~covered].any()
    assert not colour[~covered].any()
    # each model's own colour kind came through (texture, vertex, face)
    assert manifest["voxel_counts"]["core"] == sum(
        json.loads((s / "manifest.json").read_text())["voxel_counts"]["core"] for s in alone
    )


def test_auto_layout_keeps_the_gap_inside_the_tray(builds):
    tray, _ = builds
    layers, _ = _stacks(tray)
    grid = json.loads((tray / "manifest.json").read_text())["grid"]
    voxel = np.array(grid["voxel_size_mm"])[::-1]  # (z, y, x)
    origin = np.array(grid["origin_mm"])[::-1]
    parts = regionprops(label(layers > 0, connectivity=1))
    assert len(parts) == 3
    boxes = []
    for part in parts:
        low = origin + np.array(part.bbox[:3]) * voxel - voxel / 2  # voxel edges, mm
        high = origin + np.array(part.bbox[3:]) * voxel - voxel / 2
        boxes.append((low, high))
        # in the tray (z, y, x), up to the snap to the voxel grid
        assert np.all(low >= -voxel) and np.all(high <= np.array(J750_TRAY_MM[::-1]) + voxel)
    for (low_a, high_a), (low_b, high_b) in itertools.combinations(boxes, 2):
        apart = np.maximum(low_b - high_a, low_a - high_b)  # gap per axis (negative: overlap)
        assert apart.max() >= GAP_MM - 2 * voxel.max()


@pytest.mark.slow
def test_tray_build_inspects(builds, capsys):
    tray, _ = builds
    assert main(["inspect", str(tray)]) == 0
    assert "layers.tif" in capsys.readouterr().out


def test_viewer_reads_each_model_of_the_tray_as_built_alone(builds):
    """The viewer's probe (layer, colour, depth from thickness.ply) in tray coordinates."""
    tray, alone = builds
    entries = json.loads((tray / "manifest.json").read_text())["tray"]["models"]
    with BuildFolder.open(tray) as whole:
        for entry, single in zip(entries, alone, strict=True):
            layers, _ = _stacks(single)
            # a colour voxel and a backing voxel of the model built alone
            for layer in (1, 2):
                found = np.argwhere(layers == layer)
                index = found[len(found) // 2]
                shifted = index + entry["grid_offset_zyx"]
                with BuildFolder.open(single) as part:
                    expected = probe(part, *map(int, index))
                got = probe(whole, *map(int, shifted))
                assert got["layer"] == expected["layer"]
                assert got["colour"] == expected["colour"]
                assert got["depth"]["inside"] == expected["depth"]["inside"]
                assert got["depth"]["mm"] == pytest.approx(expected["depth"]["mm"], abs=1e-6)
                face = got["depth"]["face"] - entry["faces"][0]  # the tray mesh's face range
                assert face == expected["depth"]["face"]
                assert got["depth"]["layer_limits_mm"] == expected["depth"]["layer_limits_mm"]
