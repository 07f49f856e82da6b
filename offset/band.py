"""Which convex pieces make up the band a layer removes (see :mod:`offset.robust`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from offset._validate import FloatArray, IntArray
from offset.adjacency import bend_angles, edge_adjacency, face_normals
from offset.pieces import (
    MARGIN_RAD,
    Group,
    balls,
    cylinders,
    prisms,
    sectors,
    vertex_caps,
)
from offset.planar import coplanar_pairs, flat_patches, patch_prisms

#: Edges bending more than this (radians) inward get a sector. Even nearly flat reflex
#: edges need one: skipping those below 1e-3 rad left thin cracks at saddle vertices.
REFLEX_EDGE_RAD = 0.0
#: Largest angular step of the rounded arcs (radians): chords stay within
#: ``1 - cos(ARC_STEP_RAD / 2)`` (0.2 %) of the depth.
ARC_STEP_RAD = np.radians(7.5)
#: Largest angular step between neighbouring points of the vertex caps (radians): facets
#: stay within ``1 - cos(CAP_STEP_RAD / sqrt(2))`` (1.1 %) of the depth.
CAP_STEP_RAD = np.radians(12.0)
#: Neighbouring faces whose depths differ by more than this fraction of the larger get
#: the deeper face's rounded edge and corners (a depth step, :func:`_depth_steps`);
#: a smaller step leaves the shell at most that much shallower next to the edge. A
#: smoothed thickness rule steps by 1.5 % between neighbours at the median and 15 % at
#: the 99th percentile (default model): rounding every 1 % step took 8.5k pieces
#: instead of 4k; at 10 %, 168 of 5202 edges are steps.
STEP_FRACTION = 0.1


@dataclass(frozen=True)
class Features:
    """Per-mesh data the pieces of every layer are built from.

    Attributes
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    normals : (F, 3) float64
        Unit outward normals, zero rows for degenerate faces.
    areas : (F,) float64, mm^2
    prism_faces : (P,) int64
        Non-degenerate faces (each gets a prism, or shares one with its flat patch).
    coplanar : (C, 2) int64
        Edge-adjacent face pairs in one plane (:func:`offset.planar.coplanar_pairs`).
    edge_ends : (E, 2) int64
        Vertex pairs of the edges that get a sector (reflex, or next to a degenerate face;
        not where a flat patch covers both faces).
    edge_faces : (E, 2) int64
        The two faces of each such edge.
    all_edges, all_edge_faces : (A, 2) int64
        Every edge and its two faces (for depth steps, which change per layer).
    cap_vertices, ball_vertices : (C,), (B,) int64
        Ends of those edges, with a capped cone or a whole ball (normal cone wider than
        a hemisphere, or next to a degenerate face).
    axis : (V, 3) float64
        Unit mean inward normal per vertex.
    half_angle : (V,) float64, radians
        Widest incident inward normal from ``axis`` plus :data:`offset.pieces.MARGIN_RAD`.
    """

    vertices: FloatArray
    faces: IntArray
    normals: FloatArray
    areas: FloatArray
    prism_faces: IntArray
    coplanar: IntArray
    edge_ends: IntArray
    edge_faces: IntArray
    all_edges: IntArray
    all_edge_faces: IntArray
    cap_vertices: IntArray
    ball_vertices: IntArray
    axis: FloatArray
    half_angle: FloatArray


def features(vertices: FloatArray, faces: IntArray) -> Features:
    """Return the :class:`Features` of a closed, outward-oriented mesh.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    """
    normals, areas = face_normals(vertices, faces)
    adj = edge_adjacency(faces)
    bend = bend_angles(normals, vertices, adj)
    degenerate = ~np.any(normals != 0, axis=1)
    edge_sel = np.flatnonzero(
        (bend < -REFLEX_EDGE_RAD) | degenerate[adj.face_left] | degenerate[adj.face_right]
    )
    corner_vertex = faces.reshape(-1)
    corner_face = np.repeat(np.arange(len(faces)), 3)
    ball_mask = np.zeros(len(vertices), dtype=bool)
    ball_mask[adj.edges[edge_sel].reshape(-1)] = True
    # Cap axis: mean inward normal; half angle: widest incident normal plus a margin.
    axis = np.zeros_like(vertices)
    np.add.at(axis, corner_vertex, -normals[corner_face])
    axis_len = np.linalg.norm(axis, axis=1)
    axis /= np.maximum(axis_len, 1e-300)[:, None]
    cos_c = np.full(len(vertices), 1.0)
    np.minimum.at(
        cos_c, corner_vertex, np.einsum("ij,ij->i", axis[corner_vertex], -normals[corner_face])
    )
    half = np.arccos(np.clip(cos_c, -1.0, 1.0)) + MARGIN_RAD
    has_deg = np.zeros(len(vertices), dtype=bool)
    has_deg[corner_vertex[degenerate[corner_face]]] = True
    full_ball = ball_mask & ((half > np.pi / 2) | (axis_len < 1e-6) | has_deg)
    return Features(
        vertices=vertices,
        faces=faces,
        normals=normals,
        areas=areas,
        prism_faces=np.flatnonzero(~degenerate),
        coplanar=coplanar_pairs(normals, adj.face_left, adj.face_right),
        edge_ends=adj.edges[edge_sel],
        edge_faces=np.stack([adj.face_left[edge_sel], adj.face_right[edge_sel]], axis=1),
        all_edges=adj.edges,
        all_edge_faces=np.stack([adj.face_left, adj.face_right], axis=1),
        cap_vertices=np.flatnonzero(ball_mask & ~full_ball),
        ball_vertices=np.flatnonzero(full_ball),
        axis=axis,
        half_angle=half,
    )


def layer_pieces(feat: Features, d: FloatArray) -> list[Group]:
    """Return the pieces whose union is the band of depth `d` ``(F,) float64 mm``.

    Prisms take their face's depth (one prism per flat patch of equal depth, see
    :mod:`offset.planar`), sectors the larger of their two faces', vertex pieces the
    deepest incident face's. An edge inside a flat patch needs no sector (its bend is
    zero up to rounding), and a vertex whose only such edges are inside patches no cap.
    """
    v, f = feat.vertices, feat.faces
    vdepth = np.zeros(len(v))
    np.maximum.at(vdepth, f.reshape(-1), np.repeat(d, 3))
    label, n_patches = flat_patches(feat.coplanar, len(f), d)
    patches, covered = patch_prisms(v, f, feat.normals, feat.areas, label, n_patches, d)
    single = feat.prism_faces[~covered[feat.prism_faces]]
    step_ends, step_pieces = _depth_steps(feat, d)
    stepped = np.zeros(len(v), dtype=bool)
    stepped[step_ends.reshape(-1)] = True
    ef = feat.edge_faces
    inside = covered[ef[:, 0]] & (label[ef[:, 0]] == label[ef[:, 1]])
    keep = ~inside
    ends = feat.edge_ends[keep]
    on_edge = np.zeros(len(v), dtype=bool)
    on_edge[ends.reshape(-1)] = True
    # Vertices of a step get a ball (see _depth_steps) and no narrower cap of their own.
    cv = feat.cap_vertices[on_edge[feat.cap_vertices] & ~stepped[feat.cap_vertices]]
    bv = np.flatnonzero((on_edge & np.isin(np.arange(len(v)), feat.ball_vertices)) | stepped)
    return [
        prisms(v[f[single]], feat.normals[single], d[single]),
        *patches,
        *sectors(
            v[ends],
            feat.normals[ef[keep, 0]],
            feat.normals[ef[keep, 1]],
            d[ef[keep]].max(axis=1),
            ARC_STEP_RAD,
        ),
        *step_pieces,
        *vertex_caps(v[cv], vdepth[cv], feat.axis[cv], feat.half_angle[cv], CAP_STEP_RAD),
        balls(v[bv], vdepth[bv], 3),
    ]


def _proper(normals: FloatArray, pairs: IntArray) -> npt.NDArray[np.bool_]:
    """Return which face pairs ``(E, 2)`` have two non-degenerate faces."""
    return np.asarray(
        np.any(normals[pairs[:, 0]] != 0, axis=1) & np.any(normals[pairs[:, 1]] != 0, axis=1),
        dtype=bool,
    )


def _is_step(d: FloatArray, pairs: IntArray) -> npt.NDArray[np.bool_]:
    """Return which face pairs ``(E, 2)`` differ in depth by a step (:data:`STEP_FRACTION`)."""
    a, b = d[pairs[:, 0]], d[pairs[:, 1]]
    return np.asarray(np.abs(a - b) > STEP_FRACTION * np.maximum(a, b), dtype=bool)


def _depth_steps(feat: Features, d: FloatArray) -> tuple[IntArray, list[Group]]:
    """Return the edges with a depth step and the cylinders that round the deeper side.

    The band of a face ``T_a`` is more than its prism: every point within ``D_a`` of its
    edges (a cylinder about each) and corners (a ball about each). Where the neighbours
    share the depth, their own pieces cover what lies inside the part (the nearest
    feature's piece reaches every point of the band). At a step, the shallower
    neighbour's do not: the edge gets the deeper face's whole cylinder (inscribed
    polygon, :data:`ARC_STEP_RAD` steps) and its ends a ball (added by the caller), so
    the band is right also where the part wraps around the edge (an inner corner near
    the step). All inscribed: every point is within ``D_a`` of ``T_a``.

    Returns
    -------
    step_ends : (S, 2) int64
        Vertex pairs of the step edges.
    pieces : list of (points (N, P, 3) float64 mm, tris (T, 3) int64)
    """
    pairs = feat.all_edge_faces
    sel = np.flatnonzero(_proper(feat.normals, pairs) & _is_step(d, pairs))
    if sel.size == 0:
        return np.zeros((0, 2), dtype=np.int64), []
    ends = feat.all_edges[sel]
    radius = d[pairs[sel]].max(axis=1)
    return ends, [cylinders(feat.vertices[ends], radius, ARC_STEP_RAD)]
