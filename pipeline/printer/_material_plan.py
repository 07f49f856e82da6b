"""The :class:`shellvox.voxel.colour._materials.MaterialPlan` built from a profile and the settings.

The separation's columns (and so the halftone's stacking order) are the profile's
opaque colour materials in the order black, cyan, magenta, yellow, white, then clear
last: the first and the last interval of the blue-noise threshold are level sets of
the tile, the best spread, and go to black (the most visible on white) and clear
(translucency). With ``--icc`` the order is cyan, magenta, yellow, black, white, clear.

The separation inverts the two-flux model of the profile's optics
(:mod:`shellvox.voxel.colour._model_separation`), or follows a CMYK ICC profile with ``--icc``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from shellvox.config import MaterialSettings, Role
from shellvox.errors import InputError, opt
from shellvox.printer._profile import PrinterProfile
from shellvox.printer._table_cache import DiskTables
from shellvox.voxel.colour import (
    LayerModel,
    MaterialPlan,
    Separation,
    SeparationError,
    icc_separation,
    layer,
    model_separation,
    over,
    r_infinity,
)

#: Opaque colour roles in the order the halftone stacks them (see the module).
OPAQUE_ORDER: tuple[Role, ...] = ("black", "cyan", "magenta", "yellow", "white")


def build_material_plan(
    profile: PrinterProfile,
    settings: MaterialSettings,
    *,
    colour_layers: tuple[int, ...],
    n_bands: int,
    tables: DiskTables | None = None,
) -> MaterialPlan:
    """Return the plan for a stack of ``n_bands`` bands (core ``n_bands + 1``).

    `tables` is where the separation's solved table is looked for and kept (default: the
    shipped tables, then the user's cache, :meth:`DiskTables.default`).

    Raises
    ------
    InputError
        A role the profile lacks, an ICC profile that cannot be used, or colour layers
        outside ``1..n_bands + 1``.
    """
    roles: dict[str, int] = {m.role: m.index for m in profile.materials}
    backing = settings.backing_role or profile.backing_role
    core = settings.core_role or profile.core_role
    for option, role in (("backing", backing), ("core", core)):
        if role == "void" or role not in roles:
            raise InputError(
                opt(option),
                f"printer profile {profile.name!r} has no {role!r} material",
                f"use one of {sorted(r for r in roles if r != 'void')}",
            )
    clear = "clear" if "clear" in roles else None
    separation = _separation(profile, settings, roles, clear, tables or DiskTables.default())
    try:
        return MaterialPlan(
            separation=separation,
            column_materials=tuple(roles[role] for role in separation.roles),
            colour_layers=colour_layers,
            core_layer=n_bands + 1,
            backing_material=roles[backing],
            core_material=roles[core],
            halftone=settings.halftone,
            seed=settings.seed,
            tile_size=settings.tile_size,
        )
    except ValueError as error:
        raise InputError(
            None, str(error), f"check {opt('colour_layers')} and {opt('tile_size')}"
        ) from None


def _separation(
    profile: PrinterProfile,
    settings: MaterialSettings,
    roles: dict[str, int],
    clear: str | None,
    tables: DiskTables,
) -> Separation:
    """Return the ICC separation when asked for, else the mixing model's."""
    if settings.icc is not None:
        missing = [r for r in ("cyan", "magenta", "yellow", "black", "white") if r not in roles]
        if missing:
            raise InputError(
                settings.icc,
                f"an ICC separation needs cyan, magenta, yellow, black and white; printer "
                f"profile {profile.name!r} lacks {missing}",
                f"drop {opt('icc')} or use a profile with those materials",
            )
        try:
            return icc_separation(settings.icc, with_clear=clear is not None)
        except SeparationError as error:
            raise InputError(settings.icc, str(error), "give a CMYK output profile") from None
    opaque = tuple(role for role in OPAQUE_ORDER if role in roles)
    return model_separation(profile.optics, opaque, clear_role=clear, store=tables)


def layer_model(
    profile: PrinterProfile, plan: MaterialPlan, backing_mm: Sequence[float]
) -> LayerModel:
    """Return what the optical thickness rule needs of `profile` and `plan`.

    What lies beneath a colour layer is the backing layers (`backing_mm` of the backing
    material, outside in) over the core material, infinitely deep.
    """
    optics = profile.optics
    rows = tuple(index - 1 for index in plan.column_materials)  # optics row i: material i + 1
    backing, core = plan.backing_material - 1, plan.core_material - 1
    background = r_infinity(optics.k_per_mm[core], optics.s_per_mm[core])
    for thickness in reversed(tuple(backing_mm)):  # loop over backing layers, bottom up
        under = layer(optics.k_per_mm[backing], optics.s_per_mm[backing], thickness)
        background = over(under, background)
    return LayerModel(optics, plan.separation, rows, np.asarray(background, np.float64))
