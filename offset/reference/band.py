"""Which convex pieces make up the band a layer removes (:mod:`~.reference.robust`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import bend_angles, edge_adjacency, face_normals
from shellvox.offset.reference.pieces import MARGIN_RAD, Group, balls, prisms, sectors, vertex_caps
from shellvox.offset.reference.planar import coplanar_pairs, flat_patches, patch_prisms

#: Edges bending more than this (radians) inward get a sector. Even nearly flat reflex
#: edges need one: skipping those below 1e-3 rad left thin cracks at saddle vertices.
REFLEX_EDGE_RAD = 0.0
#: Largest angular step of the rounded arcs (radians): chords stay within
#: ``1 - cos(ARC_STEP_RAD / 2)`` (0.2 %) of the depth.
ARC_STEP_RAD = np.radians(7.5)
#: Largest angular step between neighbouring points of the vertex caps (radians): facets
#: stay within ``1 - cos(CAP_STEP_RAD / sqrt(2))`` (1.1 %) of the depth.
CAP_STEP_RAD = np.radians(12.0)


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
        Edge-adjacent face pairs in one plane
        (:func:`shellvox.offset.reference.planar.coplanar_pairs`).
    edge_ends : (E, 2) int64
        Vertex pairs of the edges that get a sector (reflex, or next to a degenerate face;
        not where a flat patch covers both faces).
    edge_faces : (E, 2) int64
        The two faces of each such edge.
    cap_vertices, ball_vertices : (C,), (B,) int64
        Ends of those edges, with a capped cone or a whole ball (normal cone wider than
        a hemisphere, or next to a degenerate face).
    axis : (V, 3) float64
        Unit mean inward normal per vertex.
    half_angle : (V,) float64, radians
        Widest incident inward normal from ``axis`` plus
        :data:`shellvox.offset.reference.pieces.MARGIN_RAD`.
    """

    vertices: FloatArray
    faces: IntArray
    normals: FloatArray
    areas: FloatArray
    prism_faces: IntArray
    coplanar: IntArray
    edge_ends: IntArray
    edge_faces: IntArray
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
        cap_vertices=np.flatnonzero(ball_mask & ~full_ball),
        ball_vertices=np.flatnonzero(full_ball),
        axis=axis,
        half_angle=half,
    )


def layer_pieces(feat: Features, d: FloatArray) -> list[Group]:
    """Return the pieces whose union is the band of depth `d` ``(F,) float64 mm``.

    Prisms take their face's depth (one prism per flat patch of equal depth, see
    :mod:`shellvox.offset.reference.planar`), sectors the larger of their two faces', vertex pieces
    the deepest incident face's. An edge inside a flat patch needs no sector (its bend is zero up to
    rounding), and a vertex whose only such edges are inside patches no cap.
    """
    v, f = feat.vertices, feat.faces
    vdepth = np.zeros(len(v))
    np.maximum.at(vdepth, f.reshape(-1), np.repeat(d, 3))
    label, n_patches = flat_patches(feat.coplanar, len(f), d)
    patches, covered = patch_prisms(v, f, feat.normals, feat.areas, label, n_patches, d)
    single = feat.prism_faces[~covered[feat.prism_faces]]
    ef = feat.edge_faces
    inside = covered[ef[:, 0]] & (label[ef[:, 0]] == label[ef[:, 1]])
    ends = feat.edge_ends[~inside]
    on_edge = np.zeros(len(v), dtype=bool)
    on_edge[ends.reshape(-1)] = True
    cv = feat.cap_vertices[on_edge[feat.cap_vertices]]
    bv = feat.ball_vertices[on_edge[feat.ball_vertices]]
    return [
        prisms(v[f[single]], feat.normals[single], d[single]),
        *patches,
        *sectors(
            v[ends],
            feat.normals[ef[~inside, 0]],
            feat.normals[ef[~inside, 1]],
            d[ef[~inside]].max(axis=1),
            ARC_STEP_RAD,
        ),
        *vertex_caps(v[cv], vdepth[cv], feat.axis[cv], feat.half_angle[cv], CAP_STEP_RAD),
        balls(v[bv], vdepth[bv], 3),
    ]
