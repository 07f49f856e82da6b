"""Per-face layer thickness from a thickness rule: colour, orientation, curvature, smoothing.

:func:`face_thickness` is what ``build``, ``shells`` and ``thickness`` call: it measures
each face (robust colour, normal, mean curvature), evaluates the rule (the optical
rule, :mod:`shellvox.thickness._optical_rule`, or the lightness rule,
:mod:`shellvox.thickness._lightness_rule`), applies the common limits
(:func:`shellvox.thickness._rule.limited_thickness`), smooths the colour layer over a
surface distance (:mod:`shellvox.thickness._surface_smoothing`) and stacks the backing
layers into the ``(K, F)`` thickness that :func:`shellvox.offset.offset_shells` and the distance
layer rule take. :func:`thickness_summary`
condenses it for the manifest and the ``thickness`` table.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse import linalg as sparse_linalg

from shellvox.config import as_json
from shellvox.model import ColouredMesh
from shellvox.offset.adjacency import bend_angles, edge_adjacency, face_normals
from shellvox.thickness._face_colour import FaceColour, face_colour, face_samples
from shellvox.thickness._lightness_rule import lightness_thickness
from shellvox.thickness._optical_rule import OpticalFaces, optical_thickness
from shellvox.thickness._rule import (
    DEFAULT_RULE,
    ORIENTATION_NAMES,
    ThicknessRule,
    limited_thickness,
    orientation_class,
)
from shellvox.thickness._surface_smoothing import smooth_over_distance
from shellvox.voxel.colour import LayerModel

#: Lightness bins of the summary, ``L*`` edges.
LIGHTNESS_EDGES = (0.0, 20.0, 40.0, 60.0, 80.0, 100.0)


@dataclass(frozen=True, eq=False)
class FaceThickness:
    """Layer thickness of every face, and what it was computed from.

    Attributes
    ----------
    thickness_mm : (K, F) float64, mm
        Thickness of layer ``k`` (outside in) at face ``f``; colour layers follow the
        rule, backing layers are constant.
    colour_layer_mm : (F,) float64, mm
        The colour-layer thickness after smoothing (every colour layer has it).
    unsmoothed_mm : (F,) float64, mm
        The colour-layer thickness before smoothing (after the common limits).
    rule_mm : (F,) float64, mm
        The rule's own colour layer, before the common limits.
    colour : FaceColour
        Robust colour per face.
    normal_z : (F,) float64
        ``z`` of the unit outward normal.
    orientation : (F,) int8
        Orientation class (0 upper, 1 side, 2 lower).
    mean_curvature : (F,) float64, 1/mm
        Mean curvature at the rule's scale, positive where convex (:func:`mean_curvature`;
        zeros when the rule's curvature cap is off).
    area_mm2 : (F,) float64, mm^2
        Face areas.
    rule : ThicknessRule
        The rule used.
    optical : OpticalFaces or None
        The optical rule's mix and settling per face (None with the lightness rule).
    """

    thickness_mm: NDArray[np.float64]
    colour_layer_mm: NDArray[np.float64]
    unsmoothed_mm: NDArray[np.float64]
    rule_mm: NDArray[np.float64]
    colour: FaceColour
    normal_z: NDArray[np.float64]
    orientation: NDArray[np.int8]
    mean_curvature: NDArray[np.float64]
    area_mm2: NDArray[np.float64]
    rule: ThicknessRule
    optical: OpticalFaces | None = None


def face_thickness(
    mesh: ColouredMesh,
    rule: ThicknessRule = DEFAULT_RULE,
    *,
    colour: FaceColour | None = None,
    model: LayerModel | None = None,
) -> FaceThickness:
    """Return the ``(K, F)`` layer thickness a rule gives a mesh.

    Parameters
    ----------
    mesh : ColouredMesh
        Closed, outward-oriented model in mm.
    rule : ThicknessRule, optional
        Default :data:`shellvox.thickness._rule.DEFAULT_RULE`.
    colour : FaceColour, optional
        Precomputed :func:`shellvox.thickness._face_colour.face_colour` of ``mesh``.
    model : LayerModel, optional
        The printer's optics and separation: needed by the optical rule.

    Returns
    -------
    FaceThickness

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((10.0, 10.0, 10.0))
    >>> mesh = ColouredMesh(np.asarray(box.vertices), np.asarray(box.faces, np.int64))
    >>> from shellvox.thickness import LIGHTNESS_RULE
    >>> result = face_thickness(mesh, LIGHTNESS_RULE)  # white and opaque
    >>> result.thickness_mm.shape
    (2, 12)
    >>> float(result.thickness_mm[1].min()), float(result.thickness_mm[1].max())
    (0.5, 0.5)
    """
    normals, areas = face_normals(mesh.vertices, mesh.faces)
    if colour is None:
        colour = face_colour(mesh)
    elif len(colour.lab) != mesh.n_faces:
        raise ValueError(f"colour must describe {mesh.n_faces} faces, got {len(colour.lab)}")
    bend = rule.curvature
    curvature = (
        mean_curvature(mesh.vertices, mesh.faces, bend.radius_mm)
        if bend.max_depth_per_radius > 0
        else np.zeros(mesh.n_faces)
    )
    optical = None
    if rule.rule == "optical":
        if model is None:
            raise ValueError("the optical rule needs the printer's LayerModel (model=...)")
        optical = optical_thickness(colour, model, rule, face_samples(mesh))
        own = optical.thickness_mm
    else:
        own = lightness_thickness(colour.lightness, colour.chroma, colour.alpha, rule)
    raw = limited_thickness(own, normals[:, 2], curvature, rule)
    layer = rule.colour_layer
    centroids = mesh.vertices[mesh.faces].mean(axis=1)
    # never thinner than the face's own need: the smoothing only deepens the faces around
    # a deeper region, so the depth changes gradually
    smoothed = smooth_over_distance(centroids, normals, areas, raw, rule.smoothing.radius_mm)
    smooth = np.clip(np.maximum(raw, smoothed), layer.min_mm, layer.max_mm)
    layers = rule.layers
    thickness = np.empty((layers.n_layers, mesh.n_faces), dtype=np.float64)
    backing = iter(layers.backing_mm)
    for k in range(layers.n_layers):  # loop over layers, not faces
        thickness[k] = smooth if k + 1 in layers.colour else next(backing)
    return FaceThickness(
        thickness_mm=thickness,
        colour_layer_mm=smooth,
        unsmoothed_mm=raw,
        rule_mm=own,
        colour=colour,
        normal_z=normals[:, 2].copy(),
        orientation=orientation_class(normals[:, 2], rule.orientation),
        mean_curvature=curvature,
        area_mm2=areas,
        rule=rule,
        optical=optical,
    )


def mean_curvature(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], radius_mm: float
) -> NDArray[np.float64]:
    """Return the mean curvature per face at the scale ``radius_mm``.

    The local estimate comes from the dihedral angles: an edge carries the total mean
    curvature ``theta_e |e| / 2`` (``theta_e`` its bend angle, positive where convex),
    half of it to each of its faces. On its own, ``H_f = sum_e theta_e |e| / (4 A_f)``
    depends on the tessellation (a sharp edge's faces get ``~1 / width``), so it is
    diffused to the scale ``r``: ``H_r`` solves ``(1 - r^2 Laplacian) H_r = H_f`` on the
    face graph (area mass matrix, edge weights ``|e| / |c_f - c_g|``, conjugate
    gradients). This keeps the total mean curvature, leaves a constant field unchanged
    (``1 / R`` on a sphere of radius ``R``) and spreads a sharp 90 degree edge into
    ``pi / (8 r) exp(-g / r)`` at distance ``g`` (``0.39 / r`` on the edge itself).
    The cost is a few sparse products per iteration, linear in the faces.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Consistently outward-oriented; edges without one reverse (holes' rims,
        non-manifold edges of a mesh as it comes) join no faces.
    radius_mm : float, mm
        Scale ``r`` (``> 0``).

    Returns
    -------
    (F,) float64, 1/mm
        Positive on convex, negative on concave regions, about 0 on flat ones.
    """
    normals, areas = face_normals(vertices, faces)
    adjacency = edge_adjacency(faces, open_ok=True)
    angle = bend_angles(normals, vertices, adjacency)
    left, right = adjacency.face_left, adjacency.face_right
    length = np.linalg.norm(
        vertices[adjacency.edges[:, 1]] - vertices[adjacency.edges[:, 0]], axis=1
    )
    n = len(faces)
    share = angle * length / 4.0
    total = np.bincount(left, share, minlength=n) + np.bincount(right, share, minlength=n)
    centroids = vertices[faces].mean(axis=1)
    gap = np.linalg.norm(centroids[left] - centroids[right], axis=1)
    weight = radius_mm**2 * length / np.maximum(gap, 1e-12 * max(float(length.max()), 1e-300))
    degree = np.bincount(left, weight, minlength=n) + np.bincount(right, weight, minlength=n)
    system = sparse.csr_matrix(
        (
            np.concatenate([-weight, -weight, areas + degree]),
            (
                np.concatenate([left, right, np.arange(n)]),
                np.concatenate([right, left, np.arange(n)]),
            ),
        ),
        shape=(n, n),
    )  # M + r^2 K: symmetric positive definite
    jacobi = sparse.diags(1.0 / (areas + degree))
    solution, info = sparse_linalg.cg(
        system,
        total,
        x0=total / np.maximum(areas, 1e-300),
        M=jacobi,
        rtol=1e-7,
        atol=0.0,
        maxiter=10 * n,
    )
    if info != 0:
        raise RuntimeError(f"mean curvature diffusion did not converge (cg info {info})")
    curvature: NDArray[np.float64] = np.asarray(solution, dtype=np.float64)
    return curvature


def thickness_summary(thickness: FaceThickness) -> dict[str, Any]:
    """Return a JSON-ready summary of a :class:`FaceThickness` (manifest and table).

    Returns
    -------
    dict
        ``rule`` (the rule's values), ``n_faces``, ``area_mm2``, ``layers`` (per layer:
        ``layer``, ``colour`` and area-weighted ``min_mm``, ``p50_mm``, ``max_mm``),
        ``colour_layer`` with ``by_orientation`` (``upper``, ``side``, ``lower``,
        ``all``), ``by_lightness`` (``L*`` bins) and ``translucent`` (alpha < 1) groups
        of ``faces``, ``area_mm2``, ``min_mm``, ``p50_mm``, ``max_mm`` (p50 area-weighted;
        ``None`` for empty groups), ``smoothing_change_mm`` (largest change made by the
        smoothing), ``curvature_capped_faces``, and ``colour_spread_de00`` (``p50``,
        ``p90``, ``max`` over faces and ``faces_to_split``: spread at least the rule's
        ``split.min_spread_de00``).
    """
    t = thickness
    area = t.area_mm2
    colour_mm = t.colour_layer_mm
    layers = [
        {"layer": k + 1, "colour": k + 1 in t.rule.layers.colour, **_stats(row, area)}
        for k, row in enumerate(t.thickness_mm)
    ]
    by_orientation = {
        name: _stats(colour_mm, area, t.orientation == code)
        for code, name in enumerate(ORIENTATION_NAMES)
    }
    by_orientation["all"] = _stats(colour_mm, area)
    lightness = t.colour.lightness
    edges = LIGHTNESS_EDGES
    by_lightness = []
    for low, high in itertools.pairwise(edges):
        chosen = (lightness >= low) & ((lightness < high) | (high == edges[-1]))
        by_lightness.append({"lightness": [low, high], **_stats(colour_mm, area, chosen)})
    spread = t.colour.spread_de00
    # Faces where the curvature cap binds: the rule without the cap gives more.
    uncapped = limited_thickness(t.rule_mm, t.normal_z, np.zeros_like(t.mean_curvature), t.rule)
    capped = int(np.count_nonzero(uncapped > t.unsmoothed_mm + 1e-12))
    optical = None
    if t.optical is not None:
        settled = t.optical.settled
        optical = {
            "delta_e": t.rule.colour_layer.delta_e,
            "settling_mm": _stats(t.optical.thickness_mm, area),
            "robust_colour_settling_mm": _stats(t.optical.robust_mm, area),
            "deepened_by_samples_faces": int(
                np.count_nonzero(t.optical.thickness_mm > t.optical.robust_mm)
            ),
            "not_settled_faces": int(np.count_nonzero(~settled)),
            "not_settled_area_mm2": float(area[~settled].sum()),
        }
    return {
        "rule": as_json(t.rule),
        "n_faces": len(area),
        "area_mm2": float(area.sum()),
        "layers": layers,
        "colour_layer": {
            "by_orientation": by_orientation,
            "by_lightness": by_lightness,
            "translucent": _stats(colour_mm, area, t.colour.alpha < 1.0),
            "smoothing_change_mm": float(np.abs(colour_mm - t.unsmoothed_mm).max(initial=0.0)),
            "curvature_capped_faces": capped,
        },
        "optical": optical,
        "colour_spread_de00": {
            "p50": float(np.percentile(spread, 50)),
            "p90": float(np.percentile(spread, 90)),
            "max": float(spread.max()),
            "faces_to_split": int(np.count_nonzero(spread >= t.rule.split.min_spread_de00)),
        },
    }


def _stats(
    values: NDArray[np.float64],
    areas: NDArray[np.float64],
    chosen: NDArray[np.bool_] | None = None,
) -> dict[str, Any]:
    """Faces, area and area-weighted min / median / max of a group of faces."""
    if chosen is not None:
        values, areas = values[chosen], areas[chosen]
    if len(values) == 0:
        return {"faces": 0, "area_mm2": 0.0, "min_mm": None, "p50_mm": None, "max_mm": None}
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(areas[order])
    median = values[order][np.searchsorted(cumulative, 0.5 * cumulative[-1])]
    return {
        "faces": len(values),
        "area_mm2": float(areas.sum()),
        "min_mm": float(values.min()),
        "p50_mm": float(median),
        "max_mm": float(values.max()),
    }
