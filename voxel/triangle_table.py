"""Per-face constants of the point-triangle distance (Ericson's test), as one table."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def triangle_table(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Return per face ``(F, 12) float64``: ``a``, ``b - a``, ``c - a`` and their dot products.

    Columns: ``a (3)``, ``ab (3)``, ``ac (3)``, ``ab.ab``, ``ab.ac``, ``ac.ac`` (mm, mm^2).
    """
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    a = corners[:, 0]
    ab = corners[:, 1] - a
    ac = corners[:, 2] - a
    return np.ascontiguousarray(
        np.concatenate(
            [
                a, ab, ac,
                np.einsum("fk,fk->f", ab, ab)[:, None],
                np.einsum("fk,fk->f", ab, ac)[:, None],
                np.einsum("fk,fk->f", ac, ac)[:, None],
            ],
            axis=1,
        )
    )  # fmt: skip
