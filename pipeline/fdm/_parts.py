"""The parts of an FDM project: pure geometry, arrays in and arrays out.

One object, its volumes in this order (PrusaSlicer 2.5 resolves overlaps by that order,
``slices_to_regions`` in ``PrintObjectSlice.cpp``: every model part clips the regions of all
volumes before it, and a modifier's region is its intersection with the parts before it):

1. **body** -- the model itself, a model part with the core's filament (filament 1);
2. **skin_<n>** -- one modifier per skin filament: the faces mapped to that filament,
   thickened inward to a reach deeper than the skin (``reach_mm``) along angle-weighted
   vertex normals, closed by walls on the patch's border. Neighbouring patches share those
   walls (the same inner vertex on both sides), so they neither overlap nor leave gaps;
   a modifier only ever changes the body it lies in, so a patch reaching past a thin wall
   prints nothing outside the model;
3. **core** -- the inner shell at the skin depth (:func:`shellvox.offset.offset_shells`), a model
   part with filament 1, last: it clips the patches, so the skin ends at the shell and its
   depth is the per-face depth, not the patches' reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

#: Smallest cosine between a vertex normal and an incident face's normal used to stretch
#: the inner vertex (caps the stretch at 1 / 0.3 of the reach on sharp corners).
MIN_COSINE = 0.3

#: Share of the distance at which neighbouring inner vertices would meet that they may move.
FOLD_SHARE = 0.5

PartKind = Literal["part", "modifier"]


@dataclass(frozen=True, eq=False)
class FdmPart:
    """One volume of the object.

    Attributes
    ----------
    name : str
    kind : {"part", "modifier"}
        A model part (printed) or a modifier (changes the filament of the parts before it).
    filament : int
        0-based filament index (0 is the core's).
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Outward-oriented, closed.
    """

    name: str
    kind: PartKind
    filament: int
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]


def face_normals(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Return unit outward normals ``(F, 3) float64`` (zero for degenerate faces)."""
    corner = vertices[faces]
    cross = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    normals: NDArray[np.float64] = np.divide(
        cross, length, out=np.zeros_like(cross), where=length > 0
    )
    return normals


def vertex_normals(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Return angle-weighted unit vertex normals ``(V, 3) float64``.

    Angle weights make a box corner's normal the diagonal, whatever the triangulation.
    """
    corner = vertices[faces]
    normal = face_normals(vertices, faces)
    total = np.zeros_like(vertices)
    for k in range(3):  # over the three corners of every face
        a = corner[:, (k + 1) % 3] - corner[:, k]
        b = corner[:, (k + 2) % 3] - corner[:, k]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300
        )
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        np.add.at(total, faces[:, k], angle[:, None] * normal)
    length = np.linalg.norm(total, axis=1, keepdims=True)
    normals: NDArray[np.float64] = np.divide(
        total, length, out=np.zeros_like(total), where=length > 0
    )
    return normals


def inner_vertices(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], reach_mm: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Return each vertex moved inward so that every incident face's plane moves ``>= reach``.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    reach_mm : (F,) float64, mm
        How deep the patch of each face must reach (along its normal).

    Returns
    -------
    (V, 3) float64, mm
        ``v - t_v n_v`` with ``t_v = max_f reach_f / max(n_v . n_f, MIN_COSINE)``.
    """
    normal = face_normals(vertices, faces)
    vnormal = vertex_normals(vertices, faces)
    cos = np.einsum("fkj,fj->fk", vnormal[faces], normal)
    need = reach_mm[:, None] / np.maximum(cos, MIN_COSINE)
    stretch = np.zeros(vertices.shape[0])
    np.maximum.at(stretch, faces.ravel(), need.ravel())
    # Where the surface bends faster than the reach (a rounded edge of radius below it),
    # inward vertex normals meet: an edge a-b moved by t along them shrinks to nothing
    # at t = |b - a|^2 / ((n_b - n_a) . (b - a)). Stop at FOLD_SHARE of that, so no patch
    # turns inside out (there the patch is shallower than the reach, see the module).
    a, b = faces.ravel(), np.roll(faces, -1, axis=1).ravel()
    step = vertices[b] - vertices[a]
    closing = np.einsum("ij,ij->i", vnormal[b] - vnormal[a], step)
    meet = np.full(a.shape, np.inf)
    convex = closing > 1e-12
    meet[convex] = np.einsum("ij,ij->i", step, step)[convex] / closing[convex]
    limit = np.full(vertices.shape[0], np.inf)
    np.minimum.at(limit, a, meet)
    np.minimum.at(limit, b, meet)
    stretch = np.minimum(stretch, FOLD_SHARE * limit)
    inner: NDArray[np.float64] = vertices - stretch[:, None] * vnormal
    return inner


def thick_patch(
    vertices: NDArray[np.float64],
    inner: NDArray[np.float64],
    faces: NDArray[np.int64],
    chosen: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Return the closed solid between the chosen faces and their inner copies.

    Outer faces keep their orientation, inner faces are reversed, and every border edge
    of the chosen set (its twin not chosen) gets a wall of two triangles.

    Returns
    -------
    vertices : (U, 3) float64, mm
        The used outer vertices, then their inner copies.
    faces : (M, 3) int64
    """
    picked = faces[chosen]
    used, local = _fans(picked)
    n = used.shape[0]
    edges = np.concatenate([local[:, [0, 1]], local[:, [1, 2]], local[:, [2, 0]]])
    keys = edges[:, 0] * n + edges[:, 1]
    border = edges[~np.isin(edges[:, 1] * n + edges[:, 0], keys)]
    a, b = border[:, 0], border[:, 1]
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    solid = np.concatenate([local, local[:, ::-1] + n, walls]).astype(np.int64)
    return np.concatenate([vertices[used], inner[used]]), solid


def _fans(picked: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Return one vertex per fan of the chosen faces around each vertex, and their faces.

    Two chosen faces that meet only at a vertex (a bow tie) get that vertex once each,
    so the thickened patch is 2-manifold: corners of a vertex are one fan when chosen faces
    join them across an edge (label propagation over those links, then pointer jumping).

    Returns
    -------
    used : (U,) int64
        The original vertex of each new vertex.
    local : (K, 3) int64
        The chosen faces in new vertex indices.
    """
    k = picked.shape[0]
    corner = np.arange(3 * k).reshape(k, 3)
    heads, tails = picked.ravel(), np.roll(picked, -1, axis=1).ravel()
    head_corner, tail_corner = corner.ravel(), np.roll(corner, -1, axis=1).ravel()
    n = int(picked.max()) + 1
    key = heads * n + tails
    order = np.argsort(key)
    at = np.searchsorted(key[order], tails * n + heads)
    at = np.minimum(at, key.size - 1)
    twin = order[at]
    inner = key[twin] == tails * n + heads  # the edge's twin is chosen too
    links = np.concatenate(
        [
            np.stack([head_corner[inner], tail_corner[twin[inner]]], axis=1),
            np.stack([tail_corner[inner], head_corner[twin[inner]]], axis=1),
        ]
    )
    label = np.arange(3 * k)
    while True:  # as many rounds as the widest fan has corners
        low = np.minimum(label[links[:, 0]], label[links[:, 1]])
        before = label.copy()
        np.minimum.at(label, links[:, 0], low)
        np.minimum.at(label, links[:, 1], low)
        label = label[label]
        if np.array_equal(label, before):
            break
    _, first, local = np.unique(label, return_index=True, return_inverse=True)
    used: NDArray[np.int64] = picked.ravel()[first]
    return used, local.reshape(k, 3).astype(np.int64)


def plan_parts(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    face_filament: NDArray[np.int64],
    reach_mm: NDArray[np.float64],
    core: tuple[NDArray[np.float64], NDArray[np.int64]],
) -> tuple[FdmPart, ...]:
    """Return the object's volumes in slicing order: body, skin modifiers, core.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        The model, closed and outward-oriented.
    face_filament : (F,) int64
        Filament of each face's skin (0-based; 0 is the core's, which needs no modifier).
    reach_mm : (F,) float64, mm
        How deep each face's patch reaches (deeper than its skin: the core clips it).
    core : ((C, 3) float64, (G, 3) int64)
        The inner shell at the skin depth; no core part when it has no faces.

    Returns
    -------
    tuple of FdmPart
    """
    v = np.ascontiguousarray(vertices, np.float64)
    f = np.ascontiguousarray(faces, np.int64)
    parts = [FdmPart("body", "part", 0, v, f)]
    inner = inner_vertices(v, f, np.asarray(reach_mm, np.float64))
    for filament in np.unique(face_filament):
        if filament == 0:
            continue
        pv, pf = thick_patch(v, inner, f, face_filament == filament)
        parts.append(FdmPart(f"skin_{filament + 1}", "modifier", int(filament), pv, pf))
    core_v, core_f = core
    if len(core_f):
        cv = np.ascontiguousarray(core_v, np.float64)
        parts.append(FdmPart("core", "part", 0, cv, np.ascontiguousarray(core_f, np.int64)))
    return tuple(parts)
