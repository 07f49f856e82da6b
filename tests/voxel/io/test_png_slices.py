"""The RGBA slice folder, read back with Pillow."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from shellvox.printer import load_profile
from shellvox.voxel.grid import GridSpec
from shellvox.voxel.io import SIDECAR_NAME, PngSliceWriter

GRID = GridSpec((1.0, -2.0, 0.25), load_profile("j750").voxel_mm, (23, 17, 31))


def _rgba() -> np.ndarray:
    """Colours with alpha 0 (outside), 128 (translucent) and 255 (opaque)."""
    rng = np.random.default_rng(5)
    rgba = rng.integers(0, 256, (*GRID.shape_zyx, 4)).astype(np.uint8)
    _, y, x = np.indices(GRID.shape_zyx)
    rgba[..., 3] = np.where(x < 10, 0, np.where(y < 8, 128, 255))
    return rgba


@pytest.mark.parametrize("first_row", ["max_y", "min_y"])
def test_slice_folder_reads_back_with_alpha(tmp_path, first_row):
    rgba = _rgba()
    folder = tmp_path / "slices"
    with PngSliceWriter(folder, GRID, first_row=first_row, metadata={"model": "t"}) as writer:
        for start in (0, 4, 5, 16):
            writer.write_slab(rgba[start : start + {0: 4, 4: 1, 5: 11, 16: 7}[start]])
        assert not folder.exists()  # appears only when complete
    n_z, n_y, n_x = GRID.shape_zyx
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slices"]
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted([SIDECAR_NAME] + [f"slice_{z:05d}.png" for z in range(n_z)])
    back = []
    for z in range(n_z):
        with Image.open(folder / f"slice_{z:05d}.png") as image:
            assert image.mode == "RGBA" and image.size == (n_x, n_y)
            assert image.info["dpi"] == pytest.approx((600.0, 300.0), rel=1e-4)
            back.append(np.asarray(image))
    stack = np.stack(back)
    expected = rgba[:, ::-1] if first_row == "max_y" else rgba
    np.testing.assert_array_equal(stack, expected)
    assert set(np.unique(stack[..., 3])) == {0, 128, 255}  # alpha survives
    sidecar = json.loads((folder / SIDECAR_NAME).read_text())
    assert sidecar["voxel_mm"] == pytest.approx(GRID.voxel_mm)
    assert sidecar["n_slices"] == n_z and (sidecar["width"], sidecar["height"]) == (n_x, n_y)
    assert sidecar["first_row"] == first_row and sidecar["model"] == "t"
    assert sidecar["files"] % 3 == "slice_00003.png"


def test_slice_folder_replaces_an_old_one_and_aborts_cleanly(tmp_path):
    rgba = _rgba()
    folder = tmp_path / "slices"
    folder.mkdir()
    (folder / "stale.png").write_bytes(b"old")
    with PngSliceWriter(folder, GRID, threads=1) as writer:
        writer.write_slab(rgba)
    assert not (folder / "stale.png").exists()
    assert len(list(folder.glob("slice_*.png"))) == GRID.shape_zyx[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slices"]

    def interrupted() -> None:
        with PngSliceWriter(tmp_path / "other", GRID) as writer:
            writer.write_slab(rgba[:5])
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        interrupted()
    writer = PngSliceWriter(tmp_path / "third", GRID)
    writer.write_slab(rgba[:5])
    with pytest.raises(ValueError, match="5 of 23 slices written"):
        writer.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slices"]
    writer = PngSliceWriter(tmp_path / "fourth", GRID)
    with pytest.raises(ValueError, match=r"rgba must be uint8 \(Zs, 17, 31, 4\)"):
        writer.write_slab(rgba[..., :3])
    writer.abort()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slices"]
