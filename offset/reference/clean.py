"""Remove degenerate triangles from a closed shell without changing its topology.

The robust shells (:mod:`shellvox.offset.reference.robust`) are exact where flat faces meet: where
more than three moved face planes nearly meet in one point (a vertex of valence above three, e.g.
every vertex of an icosphere), the exact offset has a cluster of vertices joined by edges of 1e-10
to 1e-3 mm, and where the pieces' facets nearly coincide (reflex edges and vertices) the Booleans
leave more; manifold3d triangulates the faces around them into slivers, down to zero area in
float32. Such a mesh is valid in float64 but does not stand up outside: merging the vertices a
reader rounds together makes it non-manifold, and tests of other tools see crossings among the
slivers.

:func:`clean_degenerate` removes both kinds down to a length ``tol`` (mm):

* every cluster of vertices joined by edges shorter than ``tol`` is collapsed to its mean
  (clusters wider than ``MAX_CLUSTER * tol`` are left alone, so no vertex moves farther);
* every triangle whose height is below ``tol`` (a corner within ``tol`` of the opposite,
  longest edge) has that edge flipped, which moves the surface by less than the height.

A collapse is refused where it would make the mesh non-manifold (the link condition) or
turn a face over; a flip where it would duplicate an edge or turn a face over; the rounds
repeat until nothing changes. :func:`clean_shell` then checks the result with the
crossing test of :mod:`shellvox.offset.crossing.intersections` and for faces folded flat onto a
neighbour (:func:`folded_faces`, a double layer that test does not see: flips and collapses among
slivers made a few on the bunny's shells) and, where it finds either, freezes the vertices around
them and cleans again, so the result is never less valid than the input. manifold3d's own
``simplify`` does not do this: it collapses short edges only below its internal epsilon (about
``1e-12`` of the extent, see ``CollapseShortEdges`` in its ``edge_op.cpp``) and keeps edges between
faces that are not coplanar.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.csgraph
import scipy.spatial

from shellvox.offset._validate import FloatArray, IntArray
from shellvox.offset.adjacency import edge_adjacency
from shellvox.offset.crossing.intersections import intersecting_pairs
from shellvox.offset.reference.clean_steps import (
    MAX_CLUSTER,
    collapse_clusters,
    count_degenerate,
    euler_characteristic,
    flip_low_faces,
    unit_normals,
)
from shellvox.offset.shells import Shell

BoolArray = npt.NDArray[np.bool_]

#: Tolerance of :func:`clean_offset_shell` as a fraction of the layer's smallest depth:
#: 1 um at 0.5 mm, far below a printer's layer (14 um and more), and a vertex moves at
#: most ``MAX_CLUSTER`` times that (0.8 % of the depth, within the caps' 1.1 %).
CLEAN_FRACTION = 2e-3
#: Rounds of collapse and flip.
MAX_ROUNDS = 12
#: Attempts of :func:`clean_shell` with more vertices frozen around crossing triangles.
MAX_FREEZES = 3
#: Two faces sharing an edge whose unit normals have a dot product below this are folded
#: flat onto each other (an opening angle below 0.08 degrees): a double layer of surface
#: that the crossing test, which ignores coplanar overlaps, does not see.
FOLD_COS = -1.0 + 1e-6


@dataclass(frozen=True)
class CleanedMesh:
    """A mesh after :func:`clean_degenerate` or :func:`clean_shell`.

    Attributes
    ----------
    vertices : (n, 3) float64, mm
    faces : (m, 3) int64
    tol_mm : float, mm
        The tolerance used (0 when the input was returned unchanged).
    n_collapsed : int
        Vertices removed by collapsing clusters.
    n_flipped : int
        Edges flipped.
    max_move_mm : float, mm
        Largest distance a vertex moved.
    short_edges : int
        Edges still shorter than the tolerance.
    thin_faces : int
        Faces still lower than the tolerance.
    """

    vertices: FloatArray
    faces: IntArray
    tol_mm: float
    n_collapsed: int
    n_flipped: int
    max_move_mm: float
    short_edges: int
    thin_faces: int


def clean_offset_shell(
    shell: Shell, *, fraction: float = CLEAN_FRACTION
) -> tuple[Shell, CleanedMesh]:
    """Return `shell` cleaned by :func:`clean_shell` at `fraction` of its smallest depth.

    Parameters
    ----------
    shell : Shell
        From :func:`shellvox.offset.offset_shells`.
    fraction : float, optional
        Tolerance as a fraction of ``shell.depth_mm.min()``; must be > 0.

    Returns
    -------
    shell : Shell
        The same layer and depths with the cleaned vertices and faces.
    cleaned : CleanedMesh
        The same arrays and what was done.
    """
    if not fraction > 0:
        raise ValueError(f"fraction must be > 0, got {fraction!r}")
    tol = fraction * float(shell.depth_mm.min())
    if shell.faces.shape[0] == 0:
        return shell, CleanedMesh(shell.vertices, shell.faces, tol, 0, 0, 0.0, 0, 0)
    cleaned = clean_shell(shell.vertices, shell.faces, tol=tol)
    return replace(shell, vertices=cleaned.vertices, faces=cleaned.faces), cleaned


def clean_shell(vertices: FloatArray, faces: IntArray, *, tol: float) -> CleanedMesh:
    """Return the shell cleaned by :func:`clean_degenerate` with no new crossings.

    Where the cleaned mesh has more crossing triangle pairs
    (:func:`shellvox.offset.crossing.intersections.intersecting_pairs`) or more folded faces
    (:func:`folded_faces`) than the input, the input vertices within ``2 * MAX_CLUSTER * tol`` of
    them are frozen and the mesh is cleaned again; after :data:`MAX_FREEZES` attempts the input is
    returned unchanged.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).
    tol : float, mm
        Shortest edge and smallest triangle height wanted; must be > 0.

    Returns
    -------
    CleanedMesh
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    before = len(intersecting_pairs(v, f))
    folds_before = len(folded_faces(v, f))
    frozen = np.zeros(len(v), dtype=bool)
    tree: scipy.spatial.cKDTree | None = None
    for _ in range(MAX_FREEZES + 1):
        cleaned, source = _clean(v, f, tol, frozen)
        pairs = intersecting_pairs(cleaned.vertices, cleaned.faces)
        folded = folded_faces(cleaned.vertices, cleaned.faces)
        if (
            len(pairs) <= before
            and len(folded) <= folds_before
            and euler_characteristic(cleaned.faces) == euler_characteristic(f)
        ):
            return cleaned
        bad = source[np.unique(cleaned.faces[np.union1d(pairs.reshape(-1), folded)])]
        if bad.size == 0:
            # Only the Euler characteristic changed (a collapse changed the topology), with
            # nothing to say where: keep the shell uncleaned (the duck at --scale 5).
            break
        tree = tree or scipy.spatial.cKDTree(v)
        near = tree.query_ball_point(v[bad.reshape(-1)], 2.0 * MAX_CLUSTER * tol)
        frozen[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])] = True
    return CleanedMesh(v, f, 0.0, 0, 0, 0.0, *count_degenerate(v, f, tol))


def folded_faces(vertices: FloatArray, faces: IntArray) -> IntArray:
    """Return the faces folded flat onto a neighbour across an edge (see :data:`FOLD_COS`).

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).

    Returns
    -------
    (k,) int64
        Sorted face indices.
    """
    if faces.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    adj = edge_adjacency(faces)
    normal = unit_normals(vertices, faces)
    dot = np.einsum("ij,ij->i", normal[adj.face_left], normal[adj.face_right])
    fold = dot < FOLD_COS
    return np.asarray(
        np.unique(np.concatenate([adj.face_left[fold], adj.face_right[fold]])), dtype=np.int64
    )


def clean_degenerate(
    vertices: FloatArray, faces: IntArray, *, tol: float, frozen: BoolArray | None = None
) -> CleanedMesh:
    """Collapse edges shorter than `tol` and flip away triangles lower than `tol`.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, consistently oriented, manifold triangles (or none).
    tol : float, mm
        Shortest edge and smallest triangle height wanted; must be > 0.
    frozen : (V,) bool, optional
        Vertices that must not move, nor lose or gain an edge.

    Returns
    -------
    CleanedMesh
        Closed, manifold and consistently oriented as the input, with the same Euler
        characteristic. Crossings are not checked here (see :func:`clean_shell`).
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    mask = np.zeros(len(v), dtype=bool) if frozen is None else np.asarray(frozen, dtype=bool)
    return _clean(v, f, tol, mask)[0]


def _clean(
    v: FloatArray, f: IntArray, tol: float, frozen: BoolArray
) -> tuple[CleanedMesh, IntArray]:
    """Return the cleaned mesh and the input index of each of its vertices."""
    if not tol > 0:
        raise ValueError(f"tol must be > 0 mm, got {tol!r}")
    if frozen.shape != (len(v),):
        raise ValueError(f"frozen must have shape ({len(v)},), got {frozen.shape}")
    origin = v
    source = np.arange(len(v))
    n_collapsed = n_flipped = 0
    for _ in range(MAX_ROUNDS):
        if f.shape[0] == 0:
            break
        v, f, keep, removed = collapse_clusters(v, f, tol, frozen[source])
        source = source[keep]
        f, flipped = flip_low_faces(v, f, tol, frozen[source])
        n_collapsed += removed
        n_flipped += flipped
        if removed == 0 and flipped == 0:
            break
    moved = float(np.linalg.norm(v - origin[source], axis=1).max()) if len(v) else 0.0
    return (
        CleanedMesh(v, f, tol, n_collapsed, n_flipped, moved, *count_degenerate(v, f, tol)),
        source,
    )
