"""Typed reading of a 3MF mesh's attributes: transforms, triangle properties, indices.

Each refuses what it cannot read with the loader's one-line :class:`InputError`.
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError
from shellvox.loading.threemf._properties import parse_numbers


def triangle_properties(
    path: Path, obj: ElementTree.Element, triangles: list[ElementTree.Element]
) -> tuple[NDArray[np.object_], NDArray[np.int64]]:
    """Property group ``(n,)`` (``""`` for none) and indices ``(n, 3)`` of each triangle.

    As lib3mf (the 3MF Consortium's reader) reads them: a triangle's own ``pid`` applies
    only with its ``p1`` (``p2`` and ``p3`` default to ``p1``); any other triangle takes
    the object's ``pid`` and ``pindex`` (0 when missing) at all three corners.
    """
    default_pid, default_index = obj.get("pid", ""), obj.get("pindex") or "0"
    own = [t.get("pid") is not None and t.get("p1") is not None for t in triangles]
    pid = np.array(
        [t.get("pid") if mine else default_pid for t, mine in zip(triangles, own, strict=True)],
        dtype=object,
    )
    indices = []
    for t, mine in zip(triangles, own, strict=True):  # attribute strings, not arithmetic
        p1 = t.get("p1", "") if mine else default_index
        indices += [p1, t.get("p2", p1), t.get("p3", p1)] if mine else [p1] * 3
    index = parse_numbers(path, "property index", indices, int).astype(np.int64).reshape(-1, 3)
    return pid, index


def transform_matrix(path: Path, text: str | None) -> NDArray[np.float64]:
    """3MF row-vector transform ``m00 ... m32`` as a 4x4 column-vector matrix."""
    matrix = np.eye(4)
    if text is None:
        return matrix
    try:
        values = np.array(text.split(), dtype=np.float64)
    except ValueError:
        values = np.array([np.nan])
    if values.shape != (12,) or not np.isfinite(values).all():
        raise InputError(
            path,
            f"has a malformed transform {text!r}",
            "a 3MF transform is 12 numbers (m00 m01 m02 ... m30 m31 m32); re-export it",
        )
    values = values.reshape(4, 3)
    matrix[:3, :3] = values[:3].T
    matrix[:3, 3] = values[3]
    scale = float(np.abs(matrix[:3, :3]).max())
    # det(M / scale) <= 1e-12 is det(M) <= 1e-12 scale^3 without scale^3 overflowing
    if scale == 0 or abs(np.linalg.det(matrix[:3, :3] / scale)) <= 1e-12:
        raise InputError(
            path,
            f"has a singular transform {text!r} (it flattens the object)",
            "re-export it with an invertible transform",
        )
    return matrix


def check_index(path: Path, index: NDArray[np.int64], size: int) -> NDArray[np.int64]:
    """Return `index` if every entry indexes a property group of `size` entries."""
    if index.min() < 0 or index.max() >= size:
        raise InputError(path, "a triangle's property index is out of range", "re-export it")
    return index
