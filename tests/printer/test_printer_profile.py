from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from shellvox.errors import InputError
from shellvox.printer import BACKGROUND_KEYS, load_profile, parse_profile, shipped_profiles

REPO = Path(__file__).resolve().parents[2]
PROFILES = REPO / "pipeline" / "printer" / "profiles"


def test_every_shipped_profile_loads():
    names = shipped_profiles()
    assert {"j750", "j850", "j850-hq", "generic-cmykw"} <= set(names)
    for name in names:
        profile = load_profile(name)
        assert profile.name == name
        assert profile.materials[0].role == "void"
        assert [m.index for m in profile.materials] == list(range(len(profile.materials)))


def test_j750_matches_the_facts_file():
    """Values of ../shared/printing/voxel-print-facts.md, typed in here independently."""
    profile = load_profile("j750")
    assert profile.voxel_mm == (25.4 / 600, 25.4 / 300, 0.027)
    assert profile.dpi == (600, 300)
    assert profile.slice_thickness_nm == 27000
    assert profile.slice_format == "gcvf"
    assert profile.max_materials == 6
    assert profile.min_slices == 30
    # air is transparent black ("air color in Red/Green/Blue/Alpha order": 0 0 0 0)
    assert profile.materials[0].rgba_key == (0, 0, 0, 0)
    by_role = {m.role: m for m in profile.materials}
    # reference sRGB (astro3D, "from the Voxel Printing guide")
    assert by_role["cyan"].display_srgb == (0, 89, 158)
    assert by_role["magenta"].display_srgb == (161, 35, 99)
    assert by_role["yellow"].display_srgb == (213, 178, 0)
    assert by_role["black"].display_srgb == (30, 30, 30)
    assert by_role["white"].display_srgb == (220, 222, 216)
    # transparent air frees opaque black for black material
    assert by_role["black"].rgba_key == (0, 0, 0, 255)
    assert by_role["cyan"].name == "VeroCyan-V"
    # GrabCAD's short names, as OpenVCAD writes them (slice2vox agrees on the first three)
    short = {role: by_role[role].job_name for role in ("cyan", "magenta", "yellow", "black")}
    assert short == {
        "cyan": "VeroCY-V",
        "magenta": "VeroMGT-V",
        "yellow": "VeroYL-V",
        "black": "VeroBlack",
    }
    assert (by_role["white"].name, by_role["white"].job_name) == ("VeroPureWhite", "VeroPureWht")
    assert by_role["clear"].name in ("VeroUltraClear", "VeroClear")
    assert len(profile.materials) - 1 <= 6
    assert profile.backing_role == "white"
    assert profile.core_role == "white"


def test_j850_hq_has_14_um_slices():
    assert load_profile("j850-hq").voxel_mm == (25.4 / 600, 25.4 / 300, 0.014)
    assert load_profile("j850").voxel_mm == (25.4 / 600, 25.4 / 300, 0.027)


def test_user_file_loads_and_role_lookup(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text((PROFILES / "j750.toml").read_text().replace('name = "j750"', 'name = "mine"'))
    profile = load_profile(path)
    assert profile.name == "mine"
    assert profile.source == str(path)
    assert profile.material("white").name == "VeroPureWhite"
    with pytest.raises(KeyError, match="support"):
        profile.material("support")


def _edited(tmp_path: Path, old: str, new: str, count: int = 1) -> Path:
    text = (PROFILES / "j750.toml").read_text()
    assert old in text
    path = tmp_path / "edited.toml"
    path.write_text(text.replace(old, new, count))
    return path


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (
            "rgba_key = [0, 0, 0, 255]",
            "rgba_key = [0, 0, 0, 0]",
            r"materials\[4\]\.rgba_key.*void",
        ),
        (
            "rgba_key = [255, 0, 255, 255]",
            "rgba_key = [0, 255, 255, 255]",
            r"materials\[2\]\.rgba_key.*VeroCyan-V",
        ),
        ('role = "magenta"', 'role = "cyan"', r"materials\[2\]\.role.*'cyan'"),
        ('role = "void"', 'role = "support"', r"materials\[0\]\.role.*void"),
        ('role = "yellow"', 'role = "purple"', r"materials\[3\]\.role.*must be one of"),
        ("display_srgb = [0, 89, 158]", "display_srgb = [0, 89]", r"materials\[1\]\.display_srgb"),
        ("display_srgb = [0, 89, 158]", "display_srgb = [0, 89, 300]", r"0\.\.255"),
        ("slice_thickness_nm = 27000", "", r"'slice_thickness_nm' is missing"),
        ("slice_thickness_nm = 27000", "slice_thickness_nm = -5", r"positive integer"),
        ('core_role = "white"', 'core_role = "support"', r"'core_role' names 'support'"),
        ("max_materials = 6", "max_materials = 5", r"lists 6 materials.*max_materials is 5"),
        ('slice_format = "gcvf"', 'slice_format = "stl"', r"'slice_format' must be one of"),
        ("min_slices = 30", "min_slices = 30\ncolour = 1", r"'colour' is not a profile key"),
        ('name = "VeroBlack"', 'name = "VeroBlack"\nopacity = 1', r"materials\[4\]\.opacity"),
        ("dpi = [600, 300]", "dpi = [600, 300", r"not valid TOML"),
    ],
)
def test_bad_profiles_name_file_and_key(tmp_path, old, new, match):
    path = _edited(tmp_path, old, new)
    with pytest.raises(InputError, match=match) as raised:
        load_profile(path)
    assert raised.value.path == str(path)
    assert raised.value.fix


def test_void_key_must_be_a_gcvf_background(tmp_path):
    path = _edited(tmp_path, "rgba_key = [0, 0, 0, 0]", "rgba_key = [2, 2, 2, 255]")
    with pytest.raises(InputError, match=r"materials\[0\]\.rgba_key.*background"):
        load_profile(path)
    assert BACKGROUND_KEYS == ((0, 0, 0, 0), (0, 0, 0, 255))


def test_opaque_black_air_and_no_job_names_still_load(tmp_path):
    # A profile as slice2vox writes jobs: opaque black air, black keyed 1 1 1, long names.
    text = (PROFILES / "j750.toml").read_text()
    text = text.replace("rgba_key = [0, 0, 0, 255]", "rgba_key = [1, 1, 1, 255]")
    text = text.replace("rgba_key = [0, 0, 0, 0]", "rgba_key = [0, 0, 0, 255]")
    text = "\n".join(line for line in text.splitlines() if not line.startswith("job_name"))
    path = tmp_path / "slice2vox.toml"
    path.write_text(text)
    profile = load_profile(path)
    assert profile.materials[0].rgba_key == (0, 0, 0, 255)
    assert all(m.job_name == m.name for m in profile.materials)


def test_unknown_name_and_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"unknown printer profile.*j750"):
        load_profile("x9000")
    with pytest.raises(InputError, match="not found"):
        load_profile(tmp_path / "absent.toml")


def test_parse_profile_reports_its_source():
    with pytest.raises(InputError, match=r"^here: key 'materials' is missing"):
        parse_profile('name = "x"', source="here")


def test_pyproject_ships_the_profiles():
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    patterns = pyproject["tool"]["setuptools"]["package-data"]["shellvox.printer.profiles"]
    shipped = sorted(PROFILES.glob("*.toml"))
    assert shipped
    assert any(shipped == sorted(PROFILES.glob(p)) for p in patterns)
