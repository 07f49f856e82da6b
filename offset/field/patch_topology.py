"""Half-edge topology of labelled triangles: twins, patches and their boundary loops.

The compiled kernels behind :mod:`shellvox.offset.field.planar_patches`. A half-edge ``3 t + i``
runs from ``faces[t, i]`` to ``faces[t, (i + 1) % 3]``; only triangles with a label
(``>= 0``) take part.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel._compiled import kernel

__all__ = ["at_vertices", "boundary_loops", "fans", "patches", "twins"]


@kernel
def twins(
    faces: NDArray[np.int64], n_vertices: int, tri_label: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Opposite half-edge of each half-edge ``3 t + i`` (``faces[t, i] -> faces[t, i+1]``).

    Only between labelled triangles; -1 elsewhere.
    """
    n_half = 3 * len(faces)
    count = np.zeros(n_vertices + 1, dtype=np.int64)
    for t in range(len(faces)):
        if tri_label[t] >= 0:
            for i in range(3):
                count[faces[t, i] + 1] += 1
    for v in range(n_vertices):
        count[v + 1] += count[v]
    fill = count[:-1].copy()
    out_half = np.empty(count[n_vertices], dtype=np.int64)
    out_end = np.empty(count[n_vertices], dtype=np.int64)
    for t in range(len(faces)):
        if tri_label[t] >= 0:
            for i in range(3):
                a = faces[t, i]
                out_half[fill[a]] = 3 * t + i
                out_end[fill[a]] = faces[t, (i + 1) % 3]
                fill[a] += 1
    twin = np.full(n_half, -1, dtype=np.int64)
    for a in range(n_vertices):
        for j in range(count[a], count[a + 1]):
            b = out_end[j]
            for i in range(count[b], count[b + 1]):
                if out_end[i] == a:
                    twin[out_half[j]] = out_half[i]
                    break
    return twin


@kernel
def patches(
    tri_label: NDArray[np.int64], twin: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Group the triangles of one label connected across edges into patches.

    Returns a patch id per triangle (-1 unlabelled) and a triangle of each patch.
    """
    n = len(tri_label)
    patch = np.full(n, -1, dtype=np.int64)
    stack = np.empty(n, dtype=np.int64)
    seeds = np.empty(n, dtype=np.int64)
    n_patches = 0
    for seed in range(n):
        if tri_label[seed] < 0 or patch[seed] >= 0:
            continue
        patch[seed] = n_patches
        seeds[n_patches] = seed
        top = 0
        stack[0] = seed
        top = 1
        while top > 0:
            top -= 1
            t = stack[top]
            for i in range(3):
                g = twin[3 * t + i]
                if g < 0:
                    continue
                s = g // 3
                if patch[s] < 0 and tri_label[s] == tri_label[t]:
                    patch[s] = n_patches
                    stack[top] = s
                    top += 1
        n_patches += 1
    return patch, seeds[:n_patches]


@kernel
def boundary_loops(
    faces: NDArray[np.int64], twin: NDArray[np.int64], patch: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Boundary loops of every patch, the patch on their left seen from outside.

    Returns the loops' vertices one after the other, the first entry of each loop (and the
    end), and each loop's patch.
    """
    n_half = 3 * len(faces)
    boundary = np.zeros(n_half, dtype=np.bool_)
    n_boundary = 0
    for h in range(n_half):
        p = patch[h // 3]
        if p >= 0 and (twin[h] < 0 or patch[twin[h] // 3] != p):
            boundary[h] = True
            n_boundary += 1
    vertex = np.empty(n_boundary, dtype=np.int64)
    start = np.empty(n_boundary + 1, dtype=np.int64)
    owner = np.empty(n_boundary, dtype=np.int64)
    seen = np.zeros(n_half, dtype=np.bool_)
    n_entries = 0
    n_loops = 0
    for h in range(n_half):
        if not boundary[h] or seen[h]:
            continue
        start[n_loops] = n_entries
        owner[n_loops] = patch[h // 3]
        n_loops += 1
        g = h
        while True:
            seen[g] = True
            vertex[n_entries] = faces[g // 3, g % 3]
            n_entries += 1
            # The next boundary half-edge around the end vertex, inside the patch.
            g = 3 * (g // 3) + (g % 3 + 1) % 3
            while not boundary[g]:
                g = twin[g]
                g = 3 * (g // 3) + (g % 3 + 1) % 3
            if g == h or seen[g]:
                break
    start[n_loops] = n_entries
    return vertex[:n_entries], start[: n_loops + 1], owner[:n_loops]


@kernel
def fans(faces: NDArray[np.int64], twin: NDArray[np.int64], n_vertices: int) -> NDArray[np.int64]:
    """Fans of triangles around every vertex: more than one is a pinch (not a 2-manifold).

    A fan is a cycle of the triangles at a vertex, each the next's neighbour across an edge
    at the vertex (``twin`` over every triangle at the vertices counted; an open fan ends
    where a half-edge has no twin). (V,) int64, 0 for a vertex of no triangle.
    """
    count = np.zeros(n_vertices, dtype=np.int64)
    seen = np.zeros(3 * len(faces), dtype=np.bool_)
    for h in range(3 * len(faces)):
        if seen[h]:
            continue
        count[faces[h // 3, h % 3]] += 1
        seen[h] = True
        # Half-edges out of the vertex: the one into it in the same triangle, then its twin.
        g = twin[3 * (h // 3) + (h % 3 + 2) % 3]
        while g >= 0 and not seen[g]:
            seen[g] = True
            g = twin[3 * (g // 3) + (g % 3 + 2) % 3]
        if g >= 0:
            continue  # closed
        # An open fan: the other way from h, to its other end.
        g = h
        while True:
            back = twin[g]
            if back < 0:
                break
            g = 3 * (back // 3) + (back % 3 + 1) % 3
            if seen[g]:
                break
            seen[g] = True
    return count


@kernel
def at_vertices(faces: NDArray[np.int64], mark: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Return which triangles have a corner at a marked vertex ((V,) bool). (T,) bool."""
    out = np.zeros(len(faces), dtype=np.bool_)
    for t in range(len(faces)):
        out[t] = mark[faces[t, 0]] or mark[faces[t, 1]] or mark[faces[t, 2]]
    return out
