"""A hierarchical hash grid over axis-aligned boxes: the candidate pairs of the crossing test.

Used by :func:`shellvox.offset.crossing.intersections.intersecting_pairs`: boxes are binned into the
cells of a fine grid or of the first coarser level that holds them, so every pair of overlapping
boxes meets in exactly one cell of one grid (see :func:`hash_grids`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.voxel._compiled import kernel

#: Boxes spanning at most this many cells of the fine grid (3 per axis) are binned there;
#: larger ones in coarser grids (see :func:`hash_grids`).
FINE_CELLS = 27


@dataclass(frozen=True)
class HashGrid:
    """The entries of one grid of :func:`hash_grids`, sorted by cell.

    In a cell: the active leaders, the active followers, the other leaders, the other
    followers (all are active without an ``active`` mask, see :func:`hash_grids`).

    Attributes
    ----------
    key, owner : (E,) int64
        Cell key and binned box (an index into ``boxes``) of every entry.
    later : (E,) int64
        Entries of its cell that this one pairs with: an active leader all entries after
        it, an active follower the other leaders, the rest none.
    skip : (E,) int64
        Entries right after this one that it does not pair with (the active followers
        after an active follower); its partners are entries ``skip + 1`` to
        ``skip + later`` after it.
    ends : (E,) int64
        Cumulative sum of ``later``.
    boxes : (B,) int64
        Box (face) index of every binned box.
    low_cell : (B, 3) int64
        Cell of every binned box's low corner.
    span : (3,) int64
        Cells per axis; ``key = (i * span[1] + j) * span[2] + k``.
    """

    key: IntArray
    owner: IntArray
    later: IntArray
    skip: IntArray
    ends: IntArray
    boxes: IntArray
    low_cell: IntArray
    span: IntArray

    def spans(self, chunk: int) -> Iterator[tuple[int, int]]:
        """Yield entry ranges ``a0, a1`` giving at most `chunk` pairs (at least one entry)."""
        total = int(self.ends[-1]) if self.ends.size else 0
        a0 = base = 0
        while base < total:
            a1 = max(int(np.searchsorted(self.ends, base + chunk, side="right")), a0 + 1)
            yield a0, a1
            a0, base = a1, int(self.ends[a1 - 1])


def hash_grids(
    lo: FloatArray, hi: FloatArray, active: npt.NDArray[np.bool_] | None = None
) -> Iterator[HashGrid]:
    """Yield the grids of a hierarchical hash grid [1]_ over the boxes ``lo, hi``.

    The fine grid's cell is the median box size ``s``; a box spanning at most
    :data:`FINE_CELLS` of its cells is binned there, a larger one at the level
    ``m >= 1`` whose cell ``S_m = s 2^(m + 1)`` is the first at least its size, where it
    spans at most 2 cells per axis. Pairs of two fine boxes are found in the fine grid;
    a pair whose larger level is ``m`` is found in level ``m``'s grid, where the boxes of
    lower levels are binned too (at most 8 cells each), but only in cells that a box of
    level ``m`` occupies, and paired only with those. A pair is kept only in the cell
    holding the low corner of the two boxes' intersection (``max(lo_i, lo_j)``), where
    both boxes are binned, so it is found once. Entries per box are thus bounded (27 in
    the fine grid, 8 per coarser level) whatever the sizes: long sliver triangles among
    tiny ones (CAD fans) never span billions of cells.

    With `active`, only the pairs with an active box are made: a cell without an active
    entry is dropped, and an inactive entry pairs only with active ones. A few large
    boxes among many small ones (the long triangles of planar patches) then cost in
    proportion to the active boxes near them, not to all boxes in their cells.

    Parameters
    ----------
    lo, hi : (F, 3) float64, mm
        Box corners.
    active : (F,) bool, optional
        The boxes a pair needs one of (all by default).

    Yields
    ------
    HashGrid

    References
    ----------
    .. [1] B. Mirtich, "Efficient algorithms for two-phase collision detection", in
       Practical Motion Planning in Robotics, Wiley, 1998 (hierarchical hash tables).
    """
    n_box = len(lo)
    if n_box < 2:
        return
    # Cells are indexed from the lowest corner (indices stay small wherever the mesh
    # is); overlaps are tested on the boxes as given (shifting rounds).
    origin = lo.min(axis=0)
    lo_c = lo - origin
    hi_c = hi - origin
    ext = (hi_c - lo_c).max(axis=1)
    scale = float(hi_c.max())
    # Cells of the median box size: on offset shells (fans of slivers) half as many
    # candidates, and twice as fast, as cells twice that size. At least 2^-20 of the
    # extent, so that a cell key (three indices in one int64) cannot overflow.
    size = max(float(np.median(ext)), scale * 2.0**-20) or 1.0
    cells = np.prod(np.floor(hi_c / size) - np.floor(lo_c / size) + 1, axis=1)
    level = np.zeros(n_box, dtype=np.int64)
    coarse = cells > FINE_CELLS
    level[coarse] = np.maximum(np.ceil(np.log2(ext[coarse] / size)).astype(np.int64) - 1, 1)
    while True:  # round-off of log2: the level's cell must hold the box's extent
        short = coarse & (ext > size * 2.0 ** (level + 1))
        if not np.any(short):
            break
        level[short] += 1
    fine = np.flatnonzero(~coarse)
    on = np.ones(n_box, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    grid = _grid(lo_c, hi_c, fine, np.ones(fine.size, dtype=bool), on[fine], size)
    if grid is not None:
        yield grid
    for m in np.unique(level[coarse]):
        boxes = np.flatnonzero(level <= m)
        grid = _grid(lo_c, hi_c, boxes, level[boxes] == m, on[boxes], size * 2.0 ** (m + 1))
        if grid is not None:
            yield grid


def _grid(
    lo_c: FloatArray,
    hi_c: FloatArray,
    boxes: IntArray,
    lead: npt.NDArray[np.bool_],
    active: npt.NDArray[np.bool_],
    size: float,
) -> HashGrid | None:
    """Bin `boxes` in cells of `size`; a pair needs a leader and an active box.

    Parameters
    ----------
    lo_c, hi_c : (F, 3) float64, mm
        Box corners shifted to be at least 0.
    boxes : (B,) int64
        Indices of the boxes binned.
    lead : (B,) bool
        Leaders: a pair is made when at least one of its boxes leads.
    active : (B,) bool
        Active boxes: a pair is made when at least one of its boxes is active.
    size : float, mm
        Cell size.

    Returns
    -------
    HashGrid or None
        None when no pair can be made.
    """
    if boxes.size < 2 or not np.any(lead) or not np.any(active):
        return None
    i0 = np.floor(lo_c[boxes] / size).astype(np.int64)
    n = np.floor(hi_c[boxes] / size).astype(np.int64) - i0 + 1
    span = (i0 + n - 1).max(axis=0) + 1
    key, owner = _cell_entries(i0, n, span)  # one int64 per cell
    # 0 active leader, 1 active follower, 2 other leader, 3 other follower
    group = np.where(lead[owner], 0, 1) + np.where(active[owner], 0, 2)
    if np.any(group):
        # Followers only matter in cells that a leader occupies, the others (inactive) in
        # cells an active one occupies, and with a leader only inactive, its followers
        # only where an active leader is.
        led = group % 2 == 0
        keep = led | np.isin(key, key[led])
        if np.any(group >= 2):
            keep &= (group < 2) | np.isin(key, key[group < 2])
            keep &= (group != 3) | np.isin(key, key[group == 0])
        key, owner, group = key[keep], owner[keep], group[keep]
    order = np.argsort(key, kind="stable") if not np.any(group) else np.lexsort((group, key))
    key_sorted = key[order]
    owner_sorted = owner[order]
    group_sorted = group[order]
    del key, owner, group, order
    start = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    size_g = np.diff(np.r_[start, key_sorted.size])
    cell_start = np.repeat(start, size_g)
    position = np.arange(key_sorted.size) - cell_start
    after = np.repeat(size_g, size_g) - position - 1
    if not np.any(group_sorted):
        later = after
        skip = np.zeros_like(later)
    else:
        # entries per cell of the active leaders, active followers and other leaders
        counts = [np.add.reduceat((group_sorted == g).astype(np.int64), start) for g in range(3)]
        n_active_lead, n_active, n_other_lead = (np.repeat(c, size_g) for c in counts)
        n_active += n_active_lead
        follower = (group_sorted == 1) & (n_other_lead > 0)
        later = np.select([group_sorted == 0, follower], [after, n_other_lead], 0)
        # an active follower skips the active followers after it, to the other leaders
        skip = np.where(follower, n_active - position - 1, 0)
    return HashGrid(
        key=np.ascontiguousarray(key_sorted),
        owner=np.ascontiguousarray(owner_sorted),
        later=np.ascontiguousarray(later, dtype=np.int64),
        skip=np.ascontiguousarray(skip, dtype=np.int64),
        ends=np.cumsum(later),
        boxes=boxes,
        low_cell=np.ascontiguousarray(i0),
        span=np.asarray(span, dtype=np.int64),
    )


@kernel
def _cell_entries(
    i0: IntArray, n: IntArray, span: IntArray
) -> tuple[IntArray, IntArray]:  # pragma: no cover (compiled)
    """Return the cell key and the box of every entry: box by box, x fastest, then y, z.

    Box ``b`` occupies the ``n[b]`` cells from ``i0[b]`` ((B, 3) int64 each); a cell's key
    is ``(i * span[1] + j) * span[2] + k``.
    """
    total = 0
    for b in range(len(i0)):
        total += n[b, 0] * n[b, 1] * n[b, 2]
    key = np.empty(total, dtype=np.int64)
    owner = np.empty(total, dtype=np.int64)
    e = 0
    for b in range(len(i0)):
        for kz in range(n[b, 2]):
            for ky in range(n[b, 1]):
                row = (i0[b, 0] * span[1] + i0[b, 1] + ky) * span[2] + i0[b, 2] + kz
                for kx in range(n[b, 0]):
                    key[e] = row + kx * span[1] * span[2]
                    owner[e] = b
                    e += 1
    return key, owner
