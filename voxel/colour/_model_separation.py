"""The separation table from the two-flux model: each node's mix whose deep layer shows it.

At every node of the sRGB table (:func:`shellvox.voxel.colour._separation.node_codes`) the target
is converted to CIELAB under the model's D50 white
(:func:`shellvox.voxel.colour._kubelka_munk.srgb_to_lab_d50`:
sRGB (D65) to XYZ, Bradford to D50) and the opaque materials' shares are those whose
mixture, infinitely deep, is closest to it in CIEDE2000, with the least-grain tie-break
(:func:`shellvox.voxel.colour._inversion.invert`). Targets outside the printable colours are
mapped to the mix of least CIEDE2000 (minimum-dE clipping); that residual is the gamut
error the report gives apart. A voxel's shares are interpolated between the nodes as for
the mixing separation; alpha below 1 brings in clear as there (``1 - alpha``).

Solving the table takes about a minute on one core, so it is kept in memory and in the
store between runs, keyed by the optics, the roles, the step and the solver's version.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._inversion import DeepColour, invert
from shellvox.voxel.colour._kubelka_munk import observer, srgb_to_lab_d50
from shellvox.voxel.colour._optics import Optics
from shellvox.voxel.colour._separation import (
    DEFAULT_STEP,
    Separation,
    SeparationError,
    TableStore,
    node_codes,
)

#: Bump when the inversion changes: stored tables of another version are not read.
_TABLE_VERSION = 2


def model_separation(
    optics: Optics,
    roles: tuple[str, ...],
    *,
    clear_role: str | None = None,
    step: int = DEFAULT_STEP,
    store: TableStore | None = None,
) -> Separation:
    """Return the two-flux model's separation of the opaque materials `roles`.

    Parameters
    ----------
    optics : Optics
        The printed materials' K and S (with their roles).
    roles : tuple of str
        Role of each opaque material, in the order the halftone stacks them.
    clear_role : str or None
        Role of a clear material (last column, takes ``1 - alpha``), or none.
    step : int
        Table spacing in sRGB codes (divides 255).
    store : TableStore, optional
        Keeps the solved table between runs.

    Raises
    ------
    SeparationError
        A role the optics lack.
    """
    missing = [r for r in roles if r not in optics.roles]
    if missing or not roles:
        raise SeparationError(f"the optics have no material of roles {missing or list(roles)}")
    rows = tuple(optics.roles.index(r) for r in roles)
    table = _model_table(optics, rows, step, store)
    all_roles = roles + ((clear_role,) if clear_role else ())
    return Separation(all_roles, step, table, clear_role is not None, "kubelka-munk")


def table_key(optics: Optics, rows: tuple[int, ...], step: int) -> str:
    """Return the store key of a model table: its inputs and the solver's version."""
    digest = hashlib.sha256()
    for array in (optics.wavelengths_nm, optics.k_per_mm[list(rows)], optics.s_per_mm[list(rows)]):
        digest.update(np.ascontiguousarray(array, np.float64).tobytes())
    digest.update(repr((optics.k1, optics.k2, step, _TABLE_VERSION)).encode())
    return "kubelka-munk-" + digest.hexdigest()[:24]


def _model_table(
    optics: Optics, rows: tuple[int, ...], step: int, store: TableStore | None
) -> NDArray[np.float32]:
    key = table_key(optics, rows, step)
    return _cached_table(key, optics, rows, step, store)


@functools.lru_cache(maxsize=4)
def _cached_table(
    key: str, optics: Optics, rows: tuple[int, ...], step: int, store: TableStore | None
) -> NDArray[np.float32]:
    cached = None if store is None else store.load(key)
    n_nodes = len(node_codes(step))
    if cached is not None and cached.shape == (n_nodes, n_nodes, n_nodes, len(rows)):
        cached.setflags(write=False)
        return cached
    table = solve_model_table(optics, rows, step)
    if store is not None:
        store.save(key, table)
    return table


def solve_model_table(optics: Optics, rows: tuple[int, ...], step: int) -> NDArray[np.float32]:
    """Solve the table ``(G, G, G, P) float32`` at every node (see the module)."""
    codes = node_codes(step)
    grid = np.stack(np.meshgrid(codes, codes, codes, indexing="ij"), axis=-1).reshape(-1, 3)
    deep = DeepColour(optics, rows)
    white = observer(optics.wavelengths_nm).white_xy
    found = invert(deep, srgb_to_lab_d50(grid / 255.0, white))
    n = len(codes)
    table = found.proportions.astype(np.float32).reshape(n, n, n, len(rows))
    table.setflags(write=False)
    return table
