"""Public entry point: inward per-face offset shells of a closed mesh."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from shellvox.offset._validate import (
    FloatArray,
    IntArray,
    check_choice,
    check_mesh,
    check_thickness,
)
from shellvox.offset.adjacency import edge_adjacency
from shellvox.offset.reference.paper import paper_offset
from shellvox.offset.reference.robust import robust_offset

Method = Literal["robust", "paper"]
METHODS: tuple[str, ...] = ("robust", "paper")


@dataclass(frozen=True)
class Shell:
    """One inner shell: the inner boundary of a layer.

    Attributes
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
        Outward-oriented triangles; ``m == 0`` when the layer fills the part (collapse).
        May hold several components.
    layer : int
        1-based layer index, outside in.
    depth_mm : (F,) float64, mm
        Cumulative depth ``D_k(f)`` for every original face.
    """

    vertices: FloatArray
    faces: IntArray
    layer: int
    depth_mm: FloatArray


def offset_shells(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    thickness: npt.ArrayLike,
    *,
    method: Method = "robust",
) -> list[Shell]:
    """Offset every face inward by its own cumulative depth, one shell per layer.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
    faces : (F, 3) array_like of int
        Closed, consistently outward-oriented triangles.
    thickness : (K, F) or (K,) array_like of float, mm
        Thickness of each layer per face (``> 0``); a ``(K,)`` array applies to all faces.
        Layer ``k`` is at cumulative depth ``D_k(f) = sum_{j <= k} t_j(f)``.
    method : {"robust", "paper"}, optional
        ``"robust"`` (default): closed, oriented, self-intersection-free, nested shells,
        see :mod:`shellvox.offset.reference.robust`. ``"paper"``: the reference construction of Zhu
        and Chen, see :mod:`shellvox.offset.reference.paper`.

    Returns
    -------
    list of Shell
        ``K`` shells, outside in.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((10.0, 10.0, 10.0))
    >>> shells = offset_shells(box.vertices, box.faces, [0.5, 1.0])
    >>> [float(s.vertices[:, 0].max()) for s in shells]
    [4.5, 3.5]
    """
    chosen = check_choice("method", method, METHODS)
    v, f = check_mesh(vertices, faces)
    t = check_thickness(thickness, f.shape[0])
    edge_adjacency(f)  # raises ValueError unless closed and consistently oriented
    depth = np.cumsum(t, axis=0)
    meshes = robust_offset(v, f, depth) if chosen == "robust" else paper_offset(v, f, depth)
    return [
        Shell(vertices=mv, faces=mf, layer=k + 1, depth_mm=np.ascontiguousarray(depth[k]))
        for k, (mv, mf) in enumerate(meshes)
    ]
