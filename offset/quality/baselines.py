"""Baselines the per-face offset must beat: vertex-normal offset and slicer contour offset."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import shapely
import trimesh

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import face_normals


def vertex_normal_offset(
    vertices: FloatArray, faces: IntArray, depth: FloatArray
) -> list[tuple[FloatArray, IntArray]]:
    """Move every vertex inward along its area-weighted normal (the naive offset).

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    depth : (K, F) float64, mm
        Cumulative depth per layer and face; a vertex moves by the area-weighted mean of
        its faces' depths.

    Returns
    -------
    list of (vertices (V, 3) float64 mm, faces (F, 3) int64)
        Same connectivity as the input, one mesh per layer.
    """
    normals, areas = face_normals(vertices, faces)
    corner_v = faces.reshape(-1)
    corner_f = np.repeat(np.arange(len(faces)), 3)
    vn = np.zeros_like(vertices)
    np.add.at(vn, corner_v, normals[corner_f] * areas[corner_f, None])
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
    weight = np.bincount(corner_v, areas[corner_f], minlength=len(vertices)).astype(np.float64)
    out = []
    for d in depth:
        vd = np.bincount(corner_v, (areas * d)[corner_f], minlength=len(vertices)).astype(
            np.float64
        )
        vd /= np.maximum(weight, 1e-300)
        out.append((vertices - vd[:, None] * vn, faces.copy()))
    return out


def slicer_thickness(
    mesh: trimesh.Trimesh,
    width_mm: float,
    points: FloatArray,
    normals: FloatArray,
    *,
    layer_height_mm: float,
    max_factor: float = 4.0,
    bisections: int = 12,
) -> FloatArray:
    """Measure, along the 3D normal, the band a slicer's 2D contour offset leaves.

    The mesh is sliced at ``z_i = z_min + (i + 1/2) h``; each slice's polygons are offset
    inward by `width_mm` (GEOS buffer with mitre joins, as slicers offset perimeters).
    From each surface point ``p`` with outward normal ``n`` we march ``q = p - s n`` and
    report the first ``s`` at which ``q`` lies inside the offset polygon of its slice
    (steps of at most ``h``, then `bisections` halvings of the bracketing step).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Closed original surface.
    width_mm : float, mm
        Contour offset width.
    points : (N, 3) float64, mm
        Points on the surface.
    normals : (N, 3) float64
        Unit outward normals at `points`.
    layer_height_mm : float, mm
        Slice spacing ``h``.
    max_factor : float, optional
        Marching stops at ``max_factor * width_mm``; points never entering the inner
        region report that value.
    bisections : int, optional
        Refinement steps of the crossing.

    Returns
    -------
    (N,) float64, mm
        Colour-band thickness along the normal.
    """
    h = layer_height_mm
    step = min(h, width_mm / 20.0)
    s = np.arange(1, int(np.ceil(max_factor * width_mm / step)) + 1) * step
    z0 = float(mesh.bounds[0, 2])
    n_slices = max(int(np.ceil((mesh.bounds[1, 2] - z0) / h)), 1)
    heights = z0 + (np.arange(n_slices) + 0.5) * h
    regions: dict[int, shapely.Geometry | None] = {}

    def inside(q: FloatArray) -> npt.NDArray[np.bool_]:
        idx = np.clip(np.floor((q[:, 2] - z0) / h).astype(np.int64), 0, n_slices - 1)
        used = np.unique(idx)
        new = [int(i) for i in used if int(i) not in regions]
        if new:
            sections = mesh.section_multiplane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], heights[new])
            for i, path in zip(new, sections, strict=True):
                regions[i] = (
                    None
                    if path is None
                    else _filled(path).buffer(-width_mm, join_style="mitre", mitre_limit=10.0)
                )
        order: npt.NDArray[np.intp] = np.asarray(np.argsort(idx, kind="stable"))
        bounds: npt.NDArray[np.intp] = np.asarray(
            np.searchsorted(idx[order], np.r_[used, used[-1] + 1])
        )
        result = np.zeros(len(q), dtype=bool)
        for j, i in enumerate(used):
            region = regions[int(i)]
            if region is not None:
                sel = order[int(bounds[j]) : int(bounds[j + 1])]
                result[sel] = shapely.contains_xy(region, q[sel, 0], q[sel, 1])
        return result

    q = points[:, None, :] - s[None, :, None] * normals[:, None, :]  # (N, S, 3)
    hit = inside(q.reshape(-1, 3)).reshape(q.shape[:2])
    found = hit.any(axis=1)
    first = np.where(found, np.argmax(hit, axis=1), len(s) - 1)
    hi_s = s[first]
    lo_s = np.where(first > 0, s[np.maximum(first - 1, 0)], 0.0)
    for _ in range(bisections):
        mid = 0.5 * (lo_s + hi_s)
        ok = inside(points - mid[:, None] * normals)
        hi_s = np.where(found & ok, mid, hi_s)
        lo_s = np.where(found & ~ok, mid, lo_s)
    return np.asarray(np.where(found, hi_s, max_factor * width_mm), dtype=np.float64)


def _filled(section: trimesh.path.Path2D) -> shapely.Geometry:
    """Fill a closed section's loops even-odd: the region it encloses.

    A plane section of a closed surface is a set of closed loops, nested where the solid has
    holes or islands; a point is inside when it is inside an odd number of loops, so the
    region is the symmetric difference of the loops' polygons. (Trimesh's own nesting of the
    loops, ``Path2D.polygons_full``, needs rtree, which shellvox does not depend on.)

    Parameters
    ----------
    section : trimesh.path.Path2D
        One section in its plane's coordinates (mm).

    Returns
    -------
    shapely.Geometry
        The enclosed region, in the same coordinates; empty when no loop closes.
    """
    region: shapely.Geometry = shapely.Polygon()
    for loop in section.discrete:
        if len(loop) < 4:  # a closed loop repeats its first point: a triangle at least
            continue
        parts = shapely.get_parts(shapely.make_valid(shapely.Polygon(loop)))
        area = [part for part in parts if part.geom_type in ("Polygon", "MultiPolygon")]
        if area:
            region = shapely.symmetric_difference(region, shapely.union_all(area))
    return region
