"""Argument checks shared by the public functions of :mod:`offset`.

Every check raises :class:`ValueError` naming the argument and the value that arrived.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def check_choice(name: str, value: object, choices: Collection[str]) -> str:
    """Return `value` if it is one of `choices`, else raise.

    Parameters
    ----------
    name : str
        Argument name used in the message.
    value : object
        Value to check.
    choices : collection of str
        Allowed values.

    Returns
    -------
    str
        `value`, unchanged.
    """
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {sorted(choices)}, got {value!r}")
    return value


def check_mesh(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> tuple[FloatArray, IntArray]:
    """Return contiguous float64 vertices and int64 faces after checking shapes and values.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
        Vertex positions; must be finite.
    faces : (F, 3) array_like of int
        Vertex indices per triangle, each in ``[0, V)``; ``F >= 4``.

    Returns
    -------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4:
        raise ValueError(f"vertices must have shape (V, 3) with V >= 4, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"vertices must be finite, got {int((~np.isfinite(v)).sum())} NaN/inf")
    f_raw = np.asarray(faces)
    if f_raw.ndim != 2 or f_raw.shape[1] != 3 or f_raw.shape[0] < 4:
        raise ValueError(f"faces must have shape (F, 3) with F >= 4, got {f_raw.shape}")
    if not np.issubdtype(f_raw.dtype, np.integer):
        raise ValueError(f"faces must hold integers, got dtype {f_raw.dtype}")
    f = np.ascontiguousarray(f_raw, dtype=np.int64)
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise ValueError(f"faces must index [0, {v.shape[0]}), got range [{f.min()}, {f.max()}]")
    return v, f


def check_thickness(thickness: npt.ArrayLike, n_faces: int) -> FloatArray:
    """Return per-layer per-face thickness as a ``(K, F)`` float64 array.

    Parameters
    ----------
    thickness : (K,) or (K, F) array_like of float, mm
        Thickness of each layer, either one value per layer or one per layer and face.
        Must be finite and strictly positive.
    n_faces : int
        Number of faces ``F`` of the mesh.

    Returns
    -------
    (K, F) float64, mm
        Thickness broadcast to every face.
    """
    t = np.asarray(thickness, dtype=np.float64)
    if t.ndim == 1:
        t = np.repeat(t[:, None], n_faces, axis=1)
    if t.ndim != 2 or t.shape[0] < 1 or t.shape[1] != n_faces:
        raise ValueError(
            f"thickness must have shape (K,) or (K, {n_faces}) with K >= 1, got {t.shape}"
        )
    if not np.all(np.isfinite(t)):
        raise ValueError(f"thickness must be finite, got {int((~np.isfinite(t)).sum())} NaN/inf")
    if not np.all(t > 0):
        raise ValueError(f"thickness must be > 0 mm, got minimum {float(t.min())!r}")
    return np.ascontiguousarray(t)
