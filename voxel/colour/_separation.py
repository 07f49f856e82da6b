"""Colour separation: sRGB + alpha of a voxel to proportions of the printer's materials.

A :class:`Separation` maps ``(N, 4) uint8`` sRGBA to ``(N, M) float32`` proportions of
``M`` colour materials (non-negative, summing to 1), from a lookup table of the opaque
proportions over a grid of sRGB colours, interpolated per voxel.

Default: the linear-light mixing model (:func:`mixing_separation`)
--------------------------------------------------------------------
A halftoned region is seen as the average of its voxels' colours in linear light, so
the proportions ``p`` of the opaque materials (display colours ``d_i``, linear RGB) are
chosen so that ``sum_i p_i d_i`` equals the target's linear RGB ``t``:

1. **Gamut.** The printable colours are the convex hull of the ``d_i``. A target
   outside it goes to the nearest hull point in linear RGB (Euclidean); inside it is
   reproduced exactly.
2. **Tie-break.** Five opaque materials in three dimensions leave a one-parameter
   family of exact mixes. Among them the one with the least expected squared CIELAB
   difference between a single voxel and the target, ``sum_i p_i |Lab(d_i) - Lab(t)|^2``,
   is taken: the least visible grain, the rule behind the "minimal brightness variation"
   halftone quadruples of Shaked et al. (1999), here with the whole CIELAB difference.
   It is linear in ``p``, so the optimum is a vertex of the family: a mix of at most four
   materials whose colours are affinely independent.
3. **Solver.** Every subset of at most four materials with affinely independent colours
   is tried at every node at once (barycentric coordinates of the projection of ``t``
   on the subset's affine hull, kept when non-negative): the nearest projection wins,
   ties (all exact fits inside the gamut) go to the least cost. This enumerates the
   vertices of the linear programme ``min c.p, D p = t, sum p = 1, p >= 0`` exactly (the
   tests check it against :func:`scipy.optimize.linprog` and :func:`scipy.optimize.nnls`)
   and takes milliseconds for the whole table, where one ``linprog`` call per node would
   take minutes.
4. **Table and interpolation.** The table holds the proportions at the sRGB codes
   ``0, step, 2 step, ..., 255`` per channel (``step`` divides 255), and a voxel's
   proportions are the trilinear interpolation of its cell's eight corners with weights
   taken in *linear light*. Reproduced colour is linear in the proportions, so inside
   the gamut the interpolated mix reproduces the target exactly (trilinear weights
   reproduce linear functions); only cells that cross the gamut boundary approximate.

Alpha (translucency)
--------------------
With a clear material, a voxel of alpha ``a`` (``0..255``) gets clear share
``1 - a / 255`` and the opaque proportions times ``a / 255``: alpha 255 gives exactly
no clear. Without one, alpha is ignored.

Optional ICC (:func:`icc_separation`)
-------------------------------------
sRGB goes through Pillow's ImageCms to the CMYK of a printer ICC profile (relative
colorimetric intent), then ``C, M, Y, K`` are proportions of cyan, magenta, yellow and
black and white takes the rest, ``W = 1 - (C + M + Y + K)``; where the inks sum to
more than 1 they are scaled to sum 1 and white is 0. The table and the interpolation
are the same as above.

References
----------
D. Shaked, N. Arad, A. Fitzhugh, I. Sobel, "Color diffusion: error diffusion for color
halftones", Proc. SPIE 3648 (1999).
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour._material_kernels import proportions_kernel
from shellvox.voxel.colour._mixing import mix_proportions
from shellvox.voxel.colour._srgb import codes_to_linear

SeparationMethod = Literal["mixing", "icc", "kubelka-munk"]

#: Default table step in sRGB codes: 52 nodes per channel (255 = 51 * 5).
DEFAULT_STEP = 5


class SeparationError(ValueError):
    """Materials or an ICC profile that cannot make a separation."""


@dataclass(frozen=True, eq=False)
class Separation:
    """Proportions of colour materials for 8-bit sRGBA colours.

    Parameters
    ----------
    roles : tuple of str
        Role of each proportion column (``"cyan"``, ..., ``"white"``, then ``"clear"``
        when ``has_clear``); the halftone uses this order.
    step : int
        Table node spacing in sRGB codes (divides 255).
    table : (G, G, G, P) float32
        Opaque proportions at the nodes, indexed ``[r, g, b]``, ``G = 255 / step + 1``,
        ``P = len(roles) - has_clear``; rows sum to 1.
    has_clear : bool
        The last column is a clear material that takes ``1 - alpha``.
    method : {"mixing", "icc", "kubelka-munk"}
        How the table was made (for the manifest).
    """

    roles: tuple[str, ...]
    step: int
    table: NDArray[np.float32]
    has_clear: bool
    method: SeparationMethod = "mixing"
    cell_index: NDArray[np.int64] = field(init=False, repr=False)
    cell_weight: NDArray[np.float32] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.step < 1 or 255 % self.step:
            raise SeparationError(f"step must divide 255, got {self.step}")
        n_nodes = 255 // self.step + 1
        n_opaque = len(self.roles) - int(self.has_clear)
        expected = (n_nodes, n_nodes, n_nodes, n_opaque)
        if self.table.shape != expected or self.table.dtype != np.float32:
            raise SeparationError(
                f"table must be {expected} float32, got {self.table.shape} {self.table.dtype}"
            )
        self.table.setflags(write=False)
        cell, weight = _cell_weights(self.step)
        object.__setattr__(self, "cell_index", cell)
        object.__setattr__(self, "cell_weight", weight)

    @property
    def n_columns(self) -> int:
        """Number of proportion columns ``M``."""
        return len(self.roles)

    def proportions(self, rgba: NDArray[np.uint8]) -> NDArray[np.float32]:
        """Return the material proportions of colours.

        Parameters
        ----------
        rgba : (N, 4) uint8
            sRGB + alpha.

        Returns
        -------
        (N, M) float32
            Proportions in the order of :attr:`roles`, each row non-negative and summing
            to 1 (to float32 rounding).

        Examples
        --------
        >>> sep = mixing_separation(("black", "white"), np.array([[0, 0, 0], [255] * 3]))
        >>> sep.proportions(np.array([[188, 188, 188, 255]], np.uint8)).round(2).tolist()
        [[0.5, 0.5]]
        """
        colours = np.asarray(rgba)
        if colours.ndim != 2 or colours.shape[1] != 4 or colours.dtype != np.uint8:
            raise ValueError(f"rgba must be (N, 4) uint8, got {colours.shape} {colours.dtype}")
        out = np.empty((len(colours), self.n_columns), dtype=np.float32)
        proportions_kernel(
            np.ascontiguousarray(colours),
            self.cell_index,
            self.cell_weight,
            self.table,
            self.has_clear,
            out,
        )
        return out


def node_codes(step: int) -> NDArray[np.uint8]:
    """Return the sRGB codes of the table nodes per channel, ``0, step, ..., 255``."""
    return np.arange(0, 256, step, dtype=np.uint8)


def mixing_separation(
    roles: tuple[str, ...],
    display_srgb: NDArray[np.integer[Any]],
    *,
    clear_role: str | None = None,
    step: int = DEFAULT_STEP,
    store: TableStore | None = None,
) -> Separation:
    """Return the linear-light mixing separation of opaque materials (see the module).

    Parameters
    ----------
    roles : tuple of str
        Role of each opaque material, in the order the halftone stacks them.
    display_srgb : (P, 3) int, 0..255
        Display colour of each opaque material.
    clear_role : str or None
        Role of a clear material (last column, takes ``1 - alpha``), or none.
    step : int
        Table spacing in sRGB codes (divides 255).
    store : TableStore, optional
        Keeps the solved table between runs.

    Raises
    ------
    SeparationError
        No materials, or roles and colours that do not match.
    """
    colours = np.asarray(display_srgb)
    if colours.ndim != 2 or colours.shape != (len(roles), 3) or not roles:
        raise SeparationError(
            f"display_srgb must be ({len(roles)}, 3) for roles {roles}, got {colours.shape}"
        )
    if np.any(colours < 0) or np.any(colours > 255):
        raise SeparationError(f"display_srgb must lie in 0..255, got {colours.tolist()}")
    table = _mixing_table(tuple(map(tuple, colours.astype(int).tolist())), step, store)
    all_roles = roles + ((clear_role,) if clear_role else ())
    return Separation(all_roles, step, table, clear_role is not None, "mixing")


#: Bump when the mixing model changes: stored tables of another version are not read.
_TABLE_VERSION = 1


class TableStore(Protocol):
    """Where solved tables are kept between runs (``shellvox.printer._table_cache.DiskTables``)."""

    def __hash__(self) -> int: ...  # a key of the in-memory cache

    def load(self, key: str) -> NDArray[np.float32] | None:
        """Return the table saved under `key`, or None."""
        ...

    def save(self, key: str, table: NDArray[np.float32]) -> None:
        """Keep `table` under `key`."""
        ...


@functools.lru_cache(maxsize=4)
def _mixing_table(
    colours: tuple[tuple[int, ...], ...], step: int, store: TableStore | None = None
) -> NDArray[np.float32]:
    """Return the mixing table ``(G, G, G, P) float32``.

    Solving it takes about two seconds, so it is kept in memory and, with a `store`, between
    runs (keyed by the colours, the step and the model's version).
    """
    key = (
        "mixing-" + hashlib.sha256(repr((colours, step, _TABLE_VERSION)).encode()).hexdigest()[:24]
    )
    cached = None if store is None else store.load(key)
    if cached is not None and cached.shape[-1] == len(colours):
        cached.setflags(write=False)
        return cached
    table = _solve_mixing_table(colours, step)
    if store is not None:
        store.save(key, table)
    return table


def _solve_mixing_table(colours: tuple[tuple[int, ...], ...], step: int) -> NDArray[np.float32]:
    """Solve the mixing table at every node (see :func:`mix_proportions`)."""
    codes = node_codes(step)
    grid = np.stack(np.meshgrid(codes, codes, codes, indexing="ij"), axis=-1).reshape(-1, 3)
    proportions = mix_proportions(
        codes_to_linear(grid).astype(np.float64),
        codes_to_linear(np.asarray(colours, dtype=np.uint8)).astype(np.float64),
    )
    n_nodes = len(codes)
    table = proportions.astype(np.float32).reshape(n_nodes, n_nodes, n_nodes, len(colours))
    table.setflags(write=False)
    return table


def icc_separation(
    icc_path: str | Path, *, with_clear: bool, step: int = DEFAULT_STEP
) -> Separation:
    """Return the separation through a CMYK ICC output profile (see the module).

    The columns are ``("cyan", "magenta", "yellow", "black", "white")`` and ``"clear"``
    when ``with_clear``.

    Raises
    ------
    SeparationError
        The file is not a readable ICC profile with a CMYK colour space.
    """
    from PIL import Image, ImageCms

    try:
        profile = ImageCms.getOpenProfile(str(icc_path))
    except (OSError, ImageCms.PyCMSError) as error:
        raise SeparationError(f"cannot read ICC profile ({error})") from None
    space = profile.profile.xcolor_space.strip()
    if space != "CMYK":
        raise SeparationError(f"ICC profile must have a CMYK colour space, got {space!r}")
    codes = node_codes(step)
    grid = np.stack(np.meshgrid(codes, codes, codes, indexing="ij"), axis=-1).reshape(-1, 3)
    transform = ImageCms.buildTransform(
        ImageCms.createProfile("sRGB"),
        profile,
        "RGB",
        "CMYK",
        renderingIntent=ImageCms.Intent.RELATIVE_COLORIMETRIC,
    )
    image = Image.fromarray(np.ascontiguousarray(grid.reshape(1, -1, 3)), "RGB")
    cmyk = np.asarray(ImageCms.applyTransform(image, transform), dtype=np.float64).reshape(-1, 4)
    table = cmyk_to_proportions(cmyk / 255.0)
    n_nodes = len(codes)
    roles = ("cyan", "magenta", "yellow", "black", "white")
    return Separation(
        roles + (("clear",) if with_clear else ()),
        step,
        table.astype(np.float32).reshape(n_nodes, n_nodes, n_nodes, 5),
        with_clear,
        "icc",
    )


def cmyk_to_proportions(cmyk: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return ``(N, 5)`` proportions C, M, Y, K, W of ink coverages ``(N, 4)`` in ``[0, 1]``.

    ``W = 1 - (C + M + Y + K)``; inks summing to more than 1 are scaled to sum 1 (W = 0).

    Examples
    --------
    >>> inks = np.array([[0.2, 0.1, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]])
    >>> cmyk_to_proportions(inks).round(6).tolist()
    [[0.2, 0.1, 0.0, 0.0, 0.7], [0.5, 0.5, 0.0, 0.0, 0.0]]
    """
    inks = np.clip(np.asarray(cmyk, dtype=np.float64), 0.0, 1.0)
    total = inks.sum(axis=1, keepdims=True)
    inks = inks / np.maximum(total, 1.0)
    return np.concatenate([inks, 1.0 - inks.sum(axis=1, keepdims=True)], axis=1)


def _cell_weights(step: int) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
    """Per sRGB code: its table cell (lower node) and the linear-light weight of the upper node."""
    codes = np.arange(256)
    cell = np.minimum(codes // step, 255 // step - 1).astype(np.int64)
    linear = codes_to_linear(codes.astype(np.uint8)).astype(np.float64)
    low = linear[cell * step]
    high = linear[(cell + 1) * step]
    weight = ((linear - low) / (high - low)).astype(np.float32)
    return cell, weight
