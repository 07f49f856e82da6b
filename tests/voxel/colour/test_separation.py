from __future__ import annotations

from pathlib import Path

import colour
import numpy as np
import pytest
from PIL import Image, ImageCms
from scipy import ndimage, optimize

from shellvox.config import MaterialSettings
from shellvox.errors import InputError
from shellvox.printer import DiskTables, build_material_plan, load_profile
from shellvox.voxel.colour import (
    SeparationError,
    cmyk_to_proportions,
    icc_separation,
    mix_proportions,
    mixing_separation,
)

#: J750 display colours (astro3D, "from the Voxel Printing guide"): K, C, M, Y, W.
ROLES = ("black", "cyan", "magenta", "yellow", "white")
DISPLAY = np.array([[30, 30, 30], [0, 89, 158], [161, 35, 99], [213, 178, 0], [220, 222, 216]])
SRGB = colour.RGB_COLOURSPACES["sRGB"]
CMYK_ICC = Path("/usr/share/color/icc/ghostscript/default_cmyk.icc")


def linear(codes):
    return colour.cctf_decoding(np.asarray(codes, dtype=np.float64) / 255.0, "sRGB")


def lab(linear_rgb):
    return colour.XYZ_to_Lab(colour.RGB_to_XYZ(linear_rgb, SRGB), SRGB.whitepoint)


def lab_cost(targets, materials):
    return ((lab(materials)[None] - lab(targets)[:, None]) ** 2).sum(axis=2)


@pytest.fixture(scope="module")
def separation():
    return mixing_separation(ROLES, DISPLAY, clear_role="clear")


def in_gamut_codes(n, seed):
    """8-bit sRGB of random mixes of the display colours (inside the gamut up to rounding)."""
    mixes = np.random.default_rng(seed).dirichlet(np.full(5, 0.6), size=n)
    encoded = colour.cctf_encoding(mixes @ linear(DISPLAY), "sRGB")
    return np.round(encoded * 255).astype(np.uint8)


def test_mix_is_the_linprog_optimum_inside_the_gamut():
    materials = linear(DISPLAY)
    targets = np.random.default_rng(3).dirichlet(np.full(5, 0.7), size=40) @ materials
    ours = mix_proportions(targets, materials)
    np.testing.assert_allclose(ours @ materials, targets, atol=1e-9)
    np.testing.assert_allclose(ours.sum(axis=1), 1.0, atol=1e-12)
    assert ours.min() >= 0
    cost = lab_cost(targets, materials)
    for target, row, p in zip(targets, cost, ours, strict=True):
        equality = np.vstack([materials.T, np.ones(5)])
        reference = optimize.linprog(
            row, A_eq=equality, b_eq=np.append(target, 1.0), bounds=(0, None), method="highs"
        )
        assert reference.status == 0
        assert row @ p == pytest.approx(reference.fun, rel=1e-6, abs=1e-6)


def test_mix_is_the_nearest_point_outside_the_gamut():
    materials = linear(DISPLAY)
    targets = np.random.default_rng(4).uniform(0, 1, size=(60, 3))
    ours = mix_proportions(targets, materials)
    assert ours.min() >= 0
    np.testing.assert_allclose(ours.sum(axis=1), 1.0, atol=1e-12)
    weight = 1e4  # the sum-to-one constraint as a heavily weighted least-squares row
    for target, p in zip(targets, ours, strict=True):
        reference, _ = optimize.nnls(
            np.vstack([materials.T, weight * np.ones(5)]), np.append(target, weight)
        )
        assert np.linalg.norm(p @ materials - reference @ materials) < 1e-4
        assert (
            np.linalg.norm(p @ materials - target)
            <= np.linalg.norm(reference @ materials - target) + 1e-6
        )


def test_proportions_are_trilinear_in_linear_light(separation):
    """Against scipy's trilinear interpolation with independently computed coordinates."""
    rgba = np.random.default_rng(5).integers(0, 256, size=(3000, 4), dtype=np.uint8)
    rgba[:, 3] = 255
    nodes = linear(np.arange(0, 256, separation.step))
    values = linear(rgba[:, :3])
    cell = np.clip(np.searchsorted(nodes, values, side="right") - 1, 0, len(nodes) - 2)
    frac = (values - nodes[cell]) / (nodes[cell + 1] - nodes[cell])
    coordinates = (cell + frac).T
    expected = np.stack(
        [
            ndimage.map_coordinates(
                separation.table[..., k].astype(np.float64), coordinates, order=1
            )
            for k in range(5)
        ],
        axis=1,
    )
    np.testing.assert_allclose(separation.proportions(rgba)[:, :5], expected, atol=2e-6)


def test_in_gamut_colours_are_reproduced_within_delta_e_3(separation):
    codes = in_gamut_codes(5000, seed=6)
    rgba = np.concatenate([codes, np.full((len(codes), 1), 255, np.uint8)], axis=1)
    mix = separation.proportions(rgba)[:, :5].astype(np.float64) @ linear(DISPLAY)
    delta_e = colour.delta_E(lab(mix), lab(linear(codes)), method="CIE 2000")
    assert delta_e.max() < 3.0


def test_proportions_are_non_negative_and_sum_to_one(separation):
    rgba = np.random.default_rng(7).integers(0, 256, size=(20000, 4), dtype=np.uint8)
    proportions = separation.proportions(rgba)
    assert proportions.shape == (20000, 6)
    assert proportions.dtype == np.float32
    assert proportions.min() >= 0
    np.testing.assert_allclose(proportions.sum(axis=1), 1.0, atol=1e-5)


def test_alpha_brings_in_clear(separation):
    rgb = np.random.default_rng(8).integers(0, 256, size=(500, 3), dtype=np.uint8)
    alpha = np.random.default_rng(9).integers(0, 256, size=(500, 1), dtype=np.uint8)
    opaque = separation.proportions(np.concatenate([rgb, np.full_like(alpha, 255)], axis=1))
    mixed = separation.proportions(np.concatenate([rgb, alpha], axis=1))
    assert np.all(opaque[:, 5] == 0.0)  # alpha 1: exactly no clear
    share = alpha[:, 0] / 255.0
    np.testing.assert_allclose(mixed[:, 5], 1 - share, atol=1e-6)
    np.testing.assert_allclose(mixed[:, :5], opaque[:, :5] * share[:, None], atol=1e-6)


def test_without_clear_alpha_is_ignored():
    separation = mixing_separation(ROLES, DISPLAY)
    rgba = np.array([[100, 150, 200, 255], [100, 150, 200, 7]], dtype=np.uint8)
    proportions = separation.proportions(rgba)
    assert proportions.shape == (2, 5)
    np.testing.assert_array_equal(proportions[0], proportions[1])


def test_bad_inputs():
    with pytest.raises(SeparationError, match=r"display_srgb must be \(2, 3\)"):
        mixing_separation(("black", "white"), DISPLAY)
    with pytest.raises(SeparationError, match="step must divide 255"):
        mixing_separation(ROLES, DISPLAY, step=4)
    with pytest.raises(ValueError, match=r"rgba must be \(N, 4\) uint8"):
        mixing_separation(ROLES, DISPLAY).proportions(np.zeros((3, 3), np.uint8))


@pytest.mark.skipif(not CMYK_ICC.is_file(), reason=f"{CMYK_ICC} absent (Debian libgs-common)")
def test_icc_separation_follows_imagecms_at_the_nodes():
    separation = icc_separation(CMYK_ICC, with_clear=True)
    assert separation.roles == ("cyan", "magenta", "yellow", "black", "white", "clear")
    codes = np.random.default_rng(10).integers(0, 52, size=(200, 3)) * separation.step
    rgb = codes.astype(np.uint8)
    transform = ImageCms.buildTransform(
        ImageCms.createProfile("sRGB"),
        ImageCms.getOpenProfile(str(CMYK_ICC)),
        "RGB",
        "CMYK",
        renderingIntent=ImageCms.Intent.RELATIVE_COLORIMETRIC,
    )
    cmyk = np.asarray(ImageCms.applyTransform(Image.fromarray(rgb[None]), transform))[0]
    inks = cmyk / 255.0
    rgba = np.concatenate([rgb, np.full((200, 1), 255, np.uint8)], axis=1)
    proportions = separation.proportions(rgba)
    total = inks.sum(axis=1)
    white = np.where(total <= 1, 1 - total, 0.0)
    scale = np.maximum(total, 1.0)[:, None]
    np.testing.assert_allclose(proportions[:, :4], inks / scale, atol=1e-6)
    np.testing.assert_allclose(proportions[:, 4], white, atol=1e-6)
    np.testing.assert_allclose(proportions[:, :5], cmyk_to_proportions(inks), atol=1e-6)


def test_icc_must_be_a_readable_cmyk_profile(tmp_path):
    rgb_profile = tmp_path / "srgb.icc"
    rgb_profile.write_bytes(ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes())
    with pytest.raises(SeparationError, match="CMYK colour space, got 'RGB'"):
        icc_separation(rgb_profile, with_clear=False)
    with pytest.raises(SeparationError, match="cannot read ICC profile"):
        icc_separation(tmp_path / "absent.icc", with_clear=False)
    settings = MaterialSettings(icc=rgb_profile)
    with pytest.raises(InputError, match=r"srgb\.icc: .*CMYK.*give a CMYK output profile"):
        build_material_plan(load_profile("j750"), settings, colour_layers=(1,), n_bands=2)


def test_mixing_table_disk_cache_round_trip(tmp_path, monkeypatch):
    from shellvox.voxel.colour import _separation as separation

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    store = DiskTables.default()
    assert store.folder == tmp_path / "shellvox"
    colours = ((0, 89, 158), (161, 35, 99), (213, 178, 0), (30, 30, 30), (220, 222, 216))
    separation._mixing_table.cache_clear()
    first = separation._mixing_table(colours, 51, store)  # solved, then written
    assert len(list(store.folder.glob("mixing-*.npy"))) == 1
    separation._mixing_table.cache_clear()
    again = separation._mixing_table(colours, 51, store)  # read from disk
    assert np.array_equal(again, separation._solve_mixing_table(colours, 51))
    assert np.array_equal(first, again)
    separation._mixing_table.cache_clear()
    (tmp_path / "shellvox").chmod(0o500)  # an unwritable cache only costs the solve
    try:
        assert np.array_equal(
            separation._mixing_table(colours, 15, store),
            separation._solve_mixing_table(colours, 15),
        )
    finally:
        (tmp_path / "shellvox").chmod(0o700)
        separation._mixing_table.cache_clear()
