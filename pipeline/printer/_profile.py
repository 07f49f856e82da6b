"""Printer profiles as data: a TOML file per printer, read into frozen dataclasses.

A profile gives the printer's voxel grid (dpi and slice thickness), tray, slice format,
limits, and its materials: each with an index (its position in the file; 0 is the void,
the slices' background), a name, a role, the RGBA key that stands for it in the slices,
the display sRGB colour a prediction of the printed colour uses, and optional optical
data. Shipped profiles are the package's resource files ``NAME.toml`` in
``shellvox.printer.profiles`` (``importlib.resources.files("shellvox.printer.profiles")``;
their comments cite the sources); ``load_profile`` takes a shipped name or a path to a
user's own file.

Examples
--------
>>> profile = load_profile("j750")
>>> [round(v, 4) for v in profile.voxel_mm]
[0.0423, 0.0847, 0.027]
>>> profile.material("black").rgba_key
(0, 0, 0, 255)
>>> profile.material("cyan").name, profile.material("cyan").job_name
('VeroCyan-V', 'VeroCY-V')
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal, NoReturn, cast, get_args

from shellvox.config import Role
from shellvox.errors import InputError
from shellvox.printer._optics_table import MATERIAL_KEYS, OpticsReader, profile_optics
from shellvox.voxel.colour import Optics, assumed_optics

MM_PER_INCH = 25.4

SliceFormat = Literal["gcvf", "png"]

#: Roles of the materials that colour a voxel (the separation's materials).
COLOUR_ROLES: tuple[Role, ...] = ("cyan", "magenta", "yellow", "black", "white", "clear")
#: Keys the void (background, air) may have in ``.gcvf`` slices: transparent black, as
#: OpenVCAD writes it and the format's template comment reads (the shipped profiles), or
#: opaque black, as slice2vox writes it. No material may use the void's key.
BACKGROUND_KEYS = ((0, 0, 0, 0), (0, 0, 0, 255))

_ROLES: tuple[str, ...] = get_args(Role)
_FORMATS: tuple[str, ...] = get_args(SliceFormat)
_TOP_KEYS = {
    "name", "description", "slice_format", "dpi", "slice_thickness_nm", "tray_mm",
    "max_materials", "min_slices", "backing_role", "core_role", "materials", "optics",
}  # fmt: skip
_MATERIAL_KEYS = {
    "name", "job_name", "role", "rgba_key", "display_srgb", "attenuation_per_mm", *MATERIAL_KEYS,
}  # fmt: skip


@dataclass(frozen=True)
class PrinterMaterial:
    """One material of a printer.

    Parameters
    ----------
    index : int
        Index in the material volume (uint8); 0 is the void.
    name : str
        The printer's name for it (``"VeroCyan-V"``).
    role : Role
        What the pipeline uses it for.
    rgba_key : (4,) int, 0..255
        The colour that stands for it in the slices.
    display_srgb : (3,) int, 0..255
        Its printed colour (sRGB) for predictions and previews.
    attenuation_per_mm : float or None, 1/mm
        Optical attenuation, when known.
    job_name : str
        The name a printer job lists it by (GrabCAD's short name, ``"VeroCY-V"``): the
        TOML key ``job_name``, else `name`.
    """

    index: int
    name: str
    role: Role
    rgba_key: tuple[int, int, int, int]
    display_srgb: tuple[int, int, int]
    attenuation_per_mm: float | None = None
    job_name: str = ""

    def __post_init__(self) -> None:
        if not self.job_name:
            object.__setattr__(self, "job_name", self.name)


@dataclass(frozen=True)
class PrinterProfile:
    """A printer: grid, tray, slice format, limits and materials.

    Parameters
    ----------
    name : str
        Profile name (``"j750"``).
    description : str
        One line for people.
    dpi : (2,) float
        Slice resolution ``(x, y)``, dots per inch.
    slice_thickness_nm : int, nm
        Layer height.
    tray_mm : (3,) float, mm
        Build tray ``(x, y, z)``.
    slice_format : {"gcvf", "png"}
        What the printer takes: a GrabCAD Voxel Print job or a folder of PNG slices.
    max_materials : int
        Non-void materials allowed in one job.
    min_slices : int
        Fewest slices a job may have.
    materials : tuple of PrinterMaterial
        ``materials[i].index == i``; ``materials[0]`` is the void.
    backing_role, core_role : Role
        Material of the backing layers and of the core.
    source : str
        File the profile was read from (for messages).
    optics : Optics or None
        Two-flux parameters of the printed materials (row ``i`` is material ``i + 1``);
        None: assumed from the display colours
        (:func:`shellvox.voxel.colour._optics.assumed_optics`).

    Raises
    ------
    InputError
        When the profile is inconsistent (names the key and the fix).
    """

    name: str
    description: str
    dpi: tuple[float, float]
    slice_thickness_nm: int
    tray_mm: tuple[float, float, float]
    slice_format: SliceFormat
    max_materials: int
    min_slices: int
    materials: tuple[PrinterMaterial, ...]
    backing_role: Role = "white"
    core_role: Role = "white"
    source: str = ""
    optics: Optics = field(default=None, compare=False, repr=False)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        _validate(self)
        if cast("Optics | None", self.optics) is None:  # not given: assumed
            optics = assumed_optics(*_printed(self.materials))
            object.__setattr__(self, "optics", optics)
        elif len(self.optics.names) != len(self.materials) - 1:
            raise InputError(
                self.source or self.name,
                f"the optics describe {len(self.optics.names)} materials, the profile has "
                f"{len(self.materials) - 1} besides the void",
                "give K and S for every printed material",
            )

    @property
    def voxel_mm(self) -> tuple[float, float, float]:
        """Voxel size ``(x, y, z)`` mm: one dot by one dot by one slice."""
        return (
            MM_PER_INCH / self.dpi[0],
            MM_PER_INCH / self.dpi[1],
            self.slice_thickness_nm / 1e6,
        )

    def material(self, role: str) -> PrinterMaterial:
        """Return the material with ``role``; ``KeyError`` naming the roles present if none."""
        for material in self.materials:
            if material.role == role:
                return material
        raise KeyError(
            f"profile {self.name!r} has no {role!r} material; it has "
            f"{sorted({m.role for m in self.materials})}"
        )

    def has_role(self, role: str) -> bool:
        """Return whether a material has ``role``."""
        return any(material.role == role for material in self.materials)


def profiles_folder() -> str:
    """Return where the shipped profiles are installed (``shellvox/printer/profiles``).

    The folder of the installed package (:func:`importlib.resources.files`), for
    messages that point at the shipped profiles as examples.
    """
    return str(resources.files("shellvox.printer") / "profiles")


def shipped_profiles() -> list[str]:
    """Return the names of the shipped profiles (resources of ``shellvox.printer.profiles``)."""
    folder = resources.files("shellvox.printer") / "profiles"
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_profile(name_or_path: str | Path) -> PrinterProfile:
    """Return the profile shipped under ``name_or_path`` or read from that TOML file.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped name (``"j750"``, see :func:`shipped_profiles`) or a ``.toml`` path.

    Raises
    ------
    InputError
        Unknown name, unreadable file, invalid TOML, or a missing, mistyped or
        inconsistent key (the message names the file, the key and the fix).

    Examples
    --------
    >>> import shellvox
    >>> profile = shellvox.load_profile("j750")
    >>> [material.name for material in profile.materials][:3]
    ['Background', 'VeroCyan-V', 'VeroMagenta-V']
    >>> profile.optics.assumed  # no measured chart yet: the optics are assumed
    True
    """
    text_name = str(name_or_path)
    path = Path(name_or_path)
    if isinstance(name_or_path, Path) or text_name.endswith(".toml") or path.is_file():
        if not path.is_file():
            raise InputError(path, "printer profile file not found", "give an existing .toml")
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise InputError(
                path, f"cannot read printer profile ({error})", "check the file"
            ) from None
        return parse_profile(text, source=str(path))
    shipped = resources.files("shellvox.printer") / "profiles" / f"{text_name.lower()}.toml"
    if not shipped.is_file():
        raise InputError(
            text_name,
            "unknown printer profile",
            f"use one of {shipped_profiles()} or a .toml file (see {profiles_folder()})",
        )
    return parse_profile(shipped.read_text(encoding="utf-8"), source=f"profiles/{shipped.name}")


def _printed(
    materials: tuple[PrinterMaterial, ...],
) -> tuple[list[str], list[Role], list[tuple[int, int, int]]]:
    """Return the names, roles and display colours of the printed materials (not the void)."""
    printed = materials[1:]
    return [m.name for m in printed], [m.role for m in printed], [m.display_srgb for m in printed]


def parse_profile(text: str, *, source: str) -> PrinterProfile:
    """Return the profile in TOML ``text``; ``source`` names it in error messages."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise InputError(source, f"not valid TOML ({error})", "fix the syntax") from None
    reader = _Reader(source)
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        reader.fail(unknown[0], "is not a profile key", f"use only {sorted(_TOP_KEYS)}")
    raw_materials = data.get("materials")
    if not isinstance(raw_materials, list) or not raw_materials:
        reader.fail("materials", "is missing or empty", "add [[materials]] tables, void first")
    materials = tuple(reader.material(index, entry) for index, entry in enumerate(raw_materials))
    optics = profile_optics(
        OpticsReader(reader.fail), data, raw_materials[1:], *_printed(materials)
    )
    dpi = reader.numbers(data, "dpi", 2)
    return PrinterProfile(
        name=reader.string(data, "name"),
        description=reader.string(data, "description"),
        dpi=(dpi[0], dpi[1]),
        slice_thickness_nm=reader.integer(data, "slice_thickness_nm"),
        tray_mm=cast(tuple[float, float, float], reader.numbers(data, "tray_mm", 3)),
        slice_format=cast(SliceFormat, reader.choice(data, "slice_format", _FORMATS)),
        max_materials=reader.integer(data, "max_materials"),
        min_slices=reader.integer(data, "min_slices"),
        materials=materials,
        backing_role=cast(Role, reader.choice(data, "backing_role", _ROLES, "white")),
        core_role=cast(Role, reader.choice(data, "core_role", _ROLES, "white")),
        source=source,
        optics=optics,
    )


class _Reader:
    """Typed access to the parsed TOML that fails with the file and the key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, problem: str, fix: str) -> NoReturn:
        raise InputError(self.source, f"key {key!r} {problem}", fix)

    def value(self, table: dict[str, Any], key: str, prefix: str, default: Any = None) -> Any:
        if key not in table:
            if default is not None:
                return default
            self.fail(prefix + key, "is missing", f"add {key} = ... (see {profiles_folder()})")
        return table[key]

    def string(self, table: dict[str, Any], key: str, prefix: str = "") -> str:
        value = self.value(table, key, prefix)
        if not isinstance(value, str) or not value.strip():
            self.fail(prefix + key, f"must be a non-empty string, got {value!r}", "quote it")
        return value

    def integer(self, table: dict[str, Any], key: str, prefix: str = "") -> int:
        value = self.value(table, key, prefix)
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            self.fail(prefix + key, f"must be a positive integer, got {value!r}", "fix it")
        return value

    def numbers(
        self, table: dict[str, Any], key: str, count: int, prefix: str = ""
    ) -> tuple[float, ...]:
        value = self.value(table, key, prefix)
        ok = isinstance(value, list) and len(value) == count
        ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        if not ok or not all(v > 0 for v in value):
            self.fail(prefix + key, f"must be {count} positive numbers, got {value!r}", "fix it")
        return tuple(float(v) for v in value)

    def codes(self, table: dict[str, Any], key: str, count: int, prefix: str) -> tuple[int, ...]:
        value = self.value(table, key, prefix)
        ok = isinstance(value, list) and len(value) == count
        ok = ok and all(type(v) is int and 0 <= v <= 255 for v in value)
        if not ok:
            self.fail(prefix + key, f"must be {count} integers 0..255, got {value!r}", "fix it")
        return tuple(int(v) for v in value)

    def choice(
        self, table: dict[str, Any], key: str, allowed: tuple[str, ...], default: str = ""
    ) -> str:
        value = self.value(table, key, "", default or None)
        if value not in allowed:
            self.fail(key, f"must be one of {list(allowed)}, got {value!r}", "use one of them")
        return str(value)

    def material(self, index: int, entry: Any) -> PrinterMaterial:
        prefix = f"materials[{index}]."
        if not isinstance(entry, dict):
            self.fail(f"materials[{index}]", "must be a table", "write it as [[materials]]")
        unknown = sorted(set(entry) - _MATERIAL_KEYS)
        if unknown:
            self.fail(prefix + unknown[0], "is not a material key", f"use {sorted(_MATERIAL_KEYS)}")
        role = self.value(entry, "role", prefix)
        if role not in _ROLES:
            self.fail(prefix + "role", f"must be one of {list(_ROLES)}, got {role!r}", "fix it")
        attenuation = entry.get("attenuation_per_mm")
        if attenuation is not None and not (
            isinstance(attenuation, int | float)
            and not isinstance(attenuation, bool)
            and attenuation > 0
        ):
            self.fail(prefix + "attenuation_per_mm", f"must be > 0, got {attenuation!r}", "fix it")
        key = self.codes(entry, "rgba_key", 4, prefix)
        srgb = self.codes(entry, "display_srgb", 3, prefix)
        name = self.string(entry, "name", prefix)
        return PrinterMaterial(
            index=index,
            name=name,
            job_name=self.string(entry, "job_name", prefix) if "job_name" in entry else name,
            role=cast(Role, role),
            rgba_key=(key[0], key[1], key[2], key[3]),
            display_srgb=(srgb[0], srgb[1], srgb[2]),
            attenuation_per_mm=None if attenuation is None else float(attenuation),
        )


def _validate(profile: PrinterProfile) -> None:
    """Raise :class:`InputError` naming the key when the profile is inconsistent."""
    source = profile.source or f"printer profile {profile.name!r}"

    def fail(key: str, problem: str, fix: str) -> NoReturn:
        raise InputError(source, f"key {key!r} {problem}", fix)

    materials = profile.materials
    if any(m.index != i for i, m in enumerate(materials)):
        fail("materials", "indices must be 0, 1, 2, ... in order", "renumber them")
    if not materials or materials[0].role != "void":
        fail("materials[0].role", "must be 'void' (index 0 is the background)", "list it first")
    for material in materials[1:]:
        if material.role == "void":
            fail(f"materials[{material.index}].role", "'void' appears twice", "keep one, first")
    if profile.slice_format == "gcvf" and materials[0].rgba_key not in BACKGROUND_KEYS:
        fail(
            "materials[0].rgba_key",
            f"must be a .gcvf background (air) key, {' or '.join(map(str, BACKGROUND_KEYS))}, "
            f"got {list(materials[0].rgba_key)}",
            "use 0 0 0 0 (transparent air)",
        )
    seen: dict[tuple[int, int, int, int], int] = {}
    for material in materials:
        if material.rgba_key in seen:
            other = materials[seen[material.rgba_key]]
            fail(
                f"materials[{material.index}].rgba_key",
                f"{list(material.rgba_key)} is also the key of {other.name!r} ({other.role}); "
                "black must not use the void's key",
                "give every material its own key (e.g. black 1 1 1 255)",
            )
        seen[material.rgba_key] = material.index
    for role in COLOUR_ROLES:
        holders = [m.index for m in materials if m.role == role]
        if len(holders) > 1:
            fail(
                f"materials[{holders[1]}].role",
                f"{role!r} is already the role of materials[{holders[0]}]",
                "keep one material per colour role",
            )
    opaque = [m for m in materials if m.role in COLOUR_ROLES and m.role != "clear"]
    if not opaque:
        fail(
            "materials", "has no opaque colour material", f"add materials with roles {COLOUR_ROLES}"
        )
    n_printed = len(materials) - 1
    if n_printed > profile.max_materials:
        fail(
            "materials",
            f"lists {n_printed} materials besides the void but max_materials is "
            f"{profile.max_materials}",
            "remove materials or raise max_materials",
        )
    for key in ("backing_role", "core_role"):
        role = getattr(profile, key)
        if role == "void" or not profile.has_role(role):
            fail(key, f"names {role!r}, which no material has", "name a role of a material")
    if not (len(profile.dpi) == 2 and all(v > 0 for v in profile.dpi)):
        fail("dpi", f"must be 2 positive numbers, got {profile.dpi}", "fix it")
    for key in ("slice_thickness_nm", "max_materials", "min_slices"):
        if getattr(profile, key) <= 0:
            fail(key, f"must be positive, got {getattr(profile, key)}", "fix it")
