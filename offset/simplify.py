"""Guarded simplification of nested closed shells: an error bound, then a no-crossing check.

The shells meshed from the layer field (``voxel.geometry._layer_field``) carry about nine
triangles per grid step squared of surface: millions on a 100 mm part. They are simplified
by Manifold's edge collapse (``manifold3d``, ``Manifold.simplify(tolerance)``: the result
keeps a subset of the vertices, stays closed and 2-manifold, and no surface moves by more
than the tolerance), and the result is accepted only when

* every shell's error against its target depth, ``|d - D_k(f)|`` with the exact nearest
  face, stays within ``GuardLimits`` (the maximum at the vertices, the face centroids and
  area-weighted samples; the 99th percentile over the samples, within its share of ``D``
  or within the unsimplified shell's own p99 plus the tolerance), and
* no two triangles of the shells cross (:func:`offset.intersections.intersecting_pairs`
  over all shells together, so a shell crossing a neighbouring one counts too).

The simplified vertices are then moved by at most 1e-8 of the part's size (seed 0), which
breaks the exact coplanarity of flat parts that MeshLab's triangle test misreads (see
:mod:`offset.for_file`); both checks run on the moved vertices, and where the move makes a
crossing (two triangles within the move of each other) the unmoved ones are checked instead.
Otherwise the tolerance is quartered and the shells simplified again from the originals;
when every try fails the unsimplified shells are kept (they are valid by construction).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import manifold3d
import numpy as np

from offset._validate import FloatArray, IntArray
from offset.intersections import intersecting_pairs
from offset.jitter import JITTER_FRACTION
from voxel.geometry._nearest import SurfaceIndex, nearest_faces

Mesh = tuple[FloatArray, IntArray]

#: Area-weighted samples of a shell for its error percentiles.
SAMPLES = 200_000


@dataclass(frozen=True)
class GuardLimits:
    """Tolerances of the guarded simplification (mm).

    Attributes
    ----------
    tolerance_mm : float
        First tolerance handed to Manifold's simplification.
    max_error_mm : float
        Largest ``|d - D|`` allowed at a vertex or a face centroid of a simplified shell.
    p99_error_share : float
        Largest 99th percentile of ``|d - D| / D`` allowed.
    tries : int
        Simplifications tried (the tolerance is quartered between tries).
    """

    tolerance_mm: float = 0.002
    max_error_mm: float = 0.05
    p99_error_share: float = 0.005
    tries: int = 3


#: The default limits.
DEFAULT_LIMITS = GuardLimits()


class Simplified(NamedTuple):
    """Shells after the guarded simplification and what it did.

    Attributes
    ----------
    meshes : list of (vertices (V, 3) float64 mm, faces (T, 3) int64)
        The shells, outside in.
    record : dict
        ``tolerance_mm`` used (0: kept unsimplified), ``tries``, ``faces_before``,
        ``faces_after``, ``raw_error_mm`` and ``error_mm`` (p99 and max of ``|d - D|`` per
        shell, before and after), ``crossing_pairs`` of the last try (-1: not counted).
    """

    meshes: list[Mesh]
    record: dict[str, Any]


def simplify_shells(
    meshes: list[Mesh],
    surface: SurfaceIndex,
    depth_mm: FloatArray,
    *,
    limits: GuardLimits = DEFAULT_LIMITS,
) -> Simplified:
    """Simplify closed shells under an error bound and a no-crossing check.

    Parameters
    ----------
    meshes : list of (vertices (V, 3) float64 mm, faces (T, 3) int64)
        Closed, outward-oriented, nested shells (empty where a layer fills the part).
    surface : SurfaceIndex
        The original surface.
    depth_mm : (K, F) float64, mm
        Target depth of each shell per original face.
    limits : GuardLimits, optional

    Returns
    -------
    Simplified
    """
    before = [len(f) for _, f in meshes]
    raw = [
        _depth_error(surface, depth_mm[k], v, f, samples_only=True)
        for k, (v, f) in enumerate(meshes)
    ]
    record: dict[str, Any] = {
        "faces_before": before,
        "tries": 0,
        "raw_error_mm": [e[:2] for e in raw],
    }
    tolerance = limits.tolerance_mm
    for attempt in range(limits.tries):
        record["tries"] = attempt + 1
        plain = [_manifold_simplify(v, f, tolerance) for v, f in meshes]
        candidate = [_jitter(v, f) for v, f in plain]
        errors = [_depth_error(surface, depth_mm[k], v, f) for k, (v, f) in enumerate(candidate)]
        record["error_mm"] = [e[:2] for e in errors]
        # The p99 may exceed the limit by what the grid alone gives (a faceted input's
        # creases), plus the tolerance; the maximum never exceeds its limit.
        within = all(
            e[1] <= limits.max_error_mm
            and (e[2] <= limits.p99_error_share or e[0] <= r[0] + tolerance)
            for e, r in zip(errors, raw, strict=True)
        )
        crossings = _crossing_pairs(candidate) if within else -1
        if crossings > 0:  # the jitter closed a near contact: try without it
            candidate = plain
            crossings = _crossing_pairs(candidate)
        record["crossing_pairs"] = crossings
        if within and crossings == 0:
            record.update(tolerance_mm=tolerance, faces_after=[len(f) for _, f in candidate])
            return Simplified(candidate, record)
        tolerance /= 4.0
    record.update(tolerance_mm=0.0, faces_after=before)
    return Simplified(meshes, record)


def _manifold_simplify(vertices: FloatArray, faces: IntArray, tolerance_mm: float) -> Mesh:
    """Return Manifold's simplification of a closed mesh (an empty mesh stays empty)."""
    if len(faces) == 0:
        return vertices, faces
    mesh = manifold3d.Mesh64(
        vert_properties=np.ascontiguousarray(vertices, dtype=np.float64),
        tri_verts=np.ascontiguousarray(faces, dtype=np.uint64),
    )
    solid = manifold3d.Manifold(mesh)
    if solid.status() != manifold3d.Error.NoError:
        raise ValueError(f"the shell is not a closed 2-manifold: Manifold says {solid.status()}")
    out = solid.simplify(tolerance_mm).to_mesh64()
    v = np.ascontiguousarray(np.asarray(out.vert_properties)[:, :3], dtype=np.float64)
    return v, np.ascontiguousarray(np.asarray(out.tri_verts), dtype=np.int64)


def _jitter(vertices: FloatArray, faces: IntArray) -> Mesh:
    """Move every vertex by at most ``JITTER_FRACTION`` of the extent (seed 0).

    The simplification leaves exactly coplanar neighbours on flat parts, which a triangle
    test without a coplanar tolerance (MeshLab's) reads as crossings at random; the
    crossing check runs on the moved vertices.
    """
    if len(vertices) == 0:
        return vertices, faces
    amplitude = JITTER_FRACTION * float(np.ptp(vertices, axis=0).max())
    move = np.random.default_rng(0).uniform(-amplitude, amplitude, vertices.shape)
    return vertices + move, faces


def _depth_error(
    surface: SurfaceIndex,
    depth: FloatArray,
    vertices: FloatArray,
    faces: IntArray,
    *,
    samples_only: bool = False,
) -> tuple[float, float, float]:
    """Return p99 and max of ``|d - D(f)|`` (mm) and the p99 of ``|d - D| / D``.

    The maximum is over the vertices, the face centroids and the samples; the percentiles
    over ``SAMPLES`` points spread by area (seed 0), so large flat triangles weigh as much
    as the many small ones along a crease. With `samples_only` (the unsimplified shells,
    tens of millions of triangles) the maximum is over the samples alone.
    """
    if len(faces) == 0:
        return 0.0, 0.0, 0.0
    tri = vertices[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    rng = np.random.default_rng(0)
    chosen = rng.choice(len(faces), SAMPLES, p=area / area.sum())
    weights = rng.dirichlet(np.ones(3), SAMPLES)
    samples = np.einsum("ni,nij->nj", weights, tri[chosen])
    points = samples if samples_only else np.concatenate([samples, vertices, tri.mean(axis=1)])
    face, distance = nearest_faces(surface, points)
    target = depth[face]
    error = np.abs(distance - target)
    return (
        float(np.percentile(error[:SAMPLES], 99)),
        float(error.max()),
        float(np.percentile(error[:SAMPLES] / target[:SAMPLES], 99)),
    )


def _crossing_pairs(meshes: list[Mesh]) -> int:
    """Return how many triangle pairs of the shells, all together, cross."""
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    vertices = np.concatenate([v for v, _ in meshes])
    faces = np.concatenate([f + offsets[k] for k, (_, f) in enumerate(meshes)])
    if len(faces) == 0:
        return 0
    return len(intersecting_pairs(vertices, faces))
