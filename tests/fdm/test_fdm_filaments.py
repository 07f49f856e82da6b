"""Filament parsing, the nearest filament in CIEDE2000, and dithering."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from shellvox.errors import FdmError
from shellvox.fdm import nearest_filament, parse_filaments
from shellvox.fdm._make import face_neighbours
from shellvox.voxel.colour import srgb8_to_lab


def test_parse_accepts_hash_or_not_and_any_case():
    assert parse_filaments("#ffffff, 00ff00").hex == ("#FFFFFF", "#00FF00")


@pytest.mark.parametrize("text", ["#FFF,#000000", "#GGGGGG,#000000", "#FFFFFF,", "#FFFFFFF,#0"])
def test_parse_refuses_bad_colours(text):
    with pytest.raises(FdmError, match="not a colour #RRGGBB"):
        parse_filaments(text)


def test_nearest_is_the_smallest_ciede2000():
    # against colour-science's CIEDE2000, pair by pair
    import colour

    filaments = parse_filaments("#FFFFFF,#FF0000,#FFFF00,#0000FF,#000000")
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (200, 3), dtype=np.uint8)
    lab = srgb8_to_lab(rgb)
    chosen = nearest_filament(lab, filaments)
    for i in range(0, 200, 7):
        differences = [
            float(colour.delta_E(lab[i], filaments.lab[j], method="CIE 2000"))
            for j in range(len(filaments))
        ]
        assert chosen[i] == int(np.argmin(differences))


def test_dithering_mixes_a_grey_from_black_and_white():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    faces = np.asarray(sphere.faces, np.int64)
    grey = srgb8_to_lab(np.full((len(faces), 3), 119, np.uint8))  # L* about 50
    filaments = parse_filaments("#FFFFFF,#000000")
    plain = nearest_filament(grey, filaments)
    dithered = nearest_filament(grey, filaments, neighbours=face_neighbours(faces))
    assert len(set(plain.tolist())) == 1
    white_share = float((dithered == 0).mean())
    assert 0.35 < white_share < 0.65, white_share
    # the mean CIELAB of the choice is near the target, the plain choice is not
    mean_lightness = filaments.lab[dithered, 0].mean()
    assert abs(mean_lightness - grey[0, 0]) < 5.0 < abs(filaments.lab[plain[0], 0] - grey[0, 0])
