"""What a mesh is as it comes: holes, parts, overlaps, buried faces, orientation.

:func:`inspect_soup` reads a merged, cleaned mesh (``prepare(..., check="report")``) that
may be open, non-manifold, inconsistently oriented or made of parts pushed into each
other, and reports what ``shellvox info`` prints. The inside of such a mesh is where the
generalised winding number ``w`` of its faces is at least 1/2
(:func:`shellvox.voxel.geometry.fast_winding_numbers`): it needs no closed mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from shellvox.model._mesh import ColouredMesh
from shellvox.model._topology import edge_report, face_parts

#: Holes whose place is reported (the largest first).
HOLES_LISTED = 3
#: The offset of the points beside a face or a vertex (inside or outside it), as a share
#: of the model's bounding-box diagonal.
SIDE_OFFSET = 1e-5


@dataclass(frozen=True)
class SoupReport:
    """Topology and solidity of a mesh as it comes.

    Parts are numbered from 0 in the order of their first face (:func:`face_parts`).

    Attributes
    ----------
    boundary_edges : int
        Edges used by one face only.
    hole_edges : (H,) int64
        Boundary edges of each hole (a loop of boundary edges), largest first.
    hole_centres : (H, 3) float64, mm
        The mean of each hole's vertices, in the order of `hole_edges`.
    non_manifold_edges : int
        Edges shared by more than two faces.
    non_manifold_at : (3,) float64 or None, mm
        The middle of the first non-manifold edge.
    misoriented_edges : int
        Edges of two faces that run the same way along them.
    part_faces : (P,) int64
        Faces of each part.
    part_closed : (P,) bool
        The part has neither boundary nor non-manifold edges.
    part_volume : (P,) float64, mm^3
        Signed volume of each part (about its own centroid, so an open part's too);
        negative: inside out.
    part_solid : (P,) bool
        The part encloses a volume: ``|part_volume| > 1e-6 * area ** 1.5`` (a sphere
        has ``0.094 * area ** 1.5``); a flat sheet does not.
    overlapping : (K, 2) int64
        Pairs ``i < j`` of closed parts where one has points inside the other (they
        intersect or one nests in the other).
    buried_faces : int
        Faces with the solid (``w >= 1/2``, parts turned outward) on both sides.
    encloses_volume : bool
        Some part encloses a volume (`part_solid`): the model is not a sheet.
    """

    boundary_edges: int
    hole_edges: NDArray[np.int64]
    hole_centres: NDArray[np.float64]
    non_manifold_edges: int
    non_manifold_at: NDArray[np.float64] | None
    misoriented_edges: int
    part_faces: NDArray[np.int64]
    part_closed: NDArray[np.bool_]
    part_volume: NDArray[np.float64]
    part_solid: NDArray[np.bool_]
    overlapping: NDArray[np.int64]
    buried_faces: int
    encloses_volume: bool

    @property
    def inside_out(self) -> NDArray[np.int64]:
        """The parts that enclose a negative volume, ``(K,) int64``."""
        return np.flatnonzero(self.part_solid & (self.part_volume < 0)).astype(np.int64)


def inspect_soup(mesh: ColouredMesh) -> SoupReport:
    """Report the holes, parts, overlaps, buried faces and orientation of a mesh.

    Parameters
    ----------
    mesh : ColouredMesh
        Vertices merged by position, no zero-area faces (``prepare(mesh,
        check="report")``), in mm; open, non-manifold or overlapping parts allowed.

    Returns
    -------
    SoupReport

    Notes
    -----
    Holes are the connected loops of boundary edges. A part's volume is the divergence
    sum about its centroid. With ``d`` a :data:`SIDE_OFFSET` share of the model's
    diagonal: two closed parts overlap where the winding number of one is at least 1/2 in
    size at a point ``d`` inside the other, beside one of its vertices (along the
    area-weighted vertex normal) or face centroids; parts that only touch do not, and
    parts that cross without any of these points inside each other are not seen. A face
    is buried where ``w >= 1/2`` at both points ``centroid +- d * normal``, ``w`` the
    winding number of all the faces with the inside-out parts turned.

    Examples
    --------
    >>> import numpy as np
    >>> from shellvox.model import ColouredMesh
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> report = inspect_soup(ColouredMesh(v, f[1:]))  # one face missing
    >>> report.boundary_edges, len(report.hole_edges), len(report.part_faces)
    (3, 1, 1)
    """
    vertices, faces = mesh.vertices, mesh.faces
    edges = edge_report(faces)
    count, part = face_parts(faces)
    hole_edges, hole_centres = _holes(vertices, edges.boundary)
    triangles = vertices[faces]
    centroids = triangles.mean(axis=1)
    part_faces = np.bincount(part, minlength=count).astype(np.int64)
    sums = np.stack([np.bincount(part, centroids[:, i], count) for i in range(3)], 1)
    centre = sums.astype(np.float64) / part_faces[:, None]
    a, b, c = (triangles[:, i] - centre[part] for i in range(3))
    volumes = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    part_volume = np.bincount(part, volumes, count).astype(np.float64)
    areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    part_solid = np.abs(part_volume) > 1e-6 * np.bincount(part, areas, count) ** 1.5
    part_of_vertex = np.zeros(len(vertices), dtype=np.int64)
    part_of_vertex[faces.ravel()] = np.repeat(part, 3)
    part_closed = np.ones(count, dtype=bool)
    for bad in (edges.boundary, edges.non_manifold):
        part_closed[part_of_vertex[bad[:, 0]]] = False
    encloses = bool(part_solid.any())
    outward = np.where((part_solid & (part_volume < 0))[part][:, None], faces[:, ::-1], faces)
    return SoupReport(
        boundary_edges=len(edges.boundary),
        hole_edges=hole_edges,
        hole_centres=hole_centres,
        non_manifold_edges=len(edges.non_manifold),
        non_manifold_at=(
            vertices[edges.non_manifold[0]].mean(axis=0) if len(edges.non_manifold) else None
        ),
        misoriented_edges=len(edges.misoriented),
        part_faces=part_faces,
        part_closed=part_closed,
        part_volume=part_volume,
        part_solid=part_solid,
        overlapping=_overlapping(vertices, outward, part, part_closed & part_solid),
        buried_faces=_buried(vertices, outward) if encloses else 0,
        encloses_volume=encloses,
    )


def _holes(
    vertices: NDArray[np.float64], boundary: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Return the boundary edges ``(H,) int64`` and centres ``(H, 3)`` mm of each hole."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(boundary) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    used, local = np.unique(boundary, return_inverse=True)
    local = local.reshape(-1, 2)
    graph = coo_matrix((np.ones(len(local)), (local[:, 0], local[:, 1])), (len(used),) * 2)
    count, loop = connected_components(graph, directed=False)
    edges = np.bincount(loop[local[:, 0]], minlength=count).astype(np.int64)
    sizes = np.bincount(loop, minlength=count)[:, None]
    centres = np.stack([np.bincount(loop, vertices[used, i], count) for i in range(3)], 1) / sizes
    order = np.argsort(-edges, kind="stable")
    return edges[order], centres[order]


def _overlapping(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    part: NDArray[np.int64],
    candidate: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """Return the pairs ``(K, 2) int64`` of candidate parts with points inside each other.

    `faces` are turned outward part by part. Memory and time grow with the faces and the
    pairs of candidate parts whose bounding boxes meet, not with the square of the parts.
    """
    from shellvox.voxel.geometry import WindingTree

    count = len(candidate)
    triangles = vertices[faces]
    areas = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    step = SIDE_OFFSET * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    low = np.full((count, 3), np.inf)
    high = np.full((count, 3), -np.inf)
    np.minimum.at(low, part, triangles.min(axis=1))
    np.maximum.at(high, part, triangles.max(axis=1))
    # Sample points of each face just inside its part: beside its centroid and beside
    # its corners (along the area-weighted vertex normals).
    normals = np.zeros_like(vertices)
    for corner in range(3):
        np.add.at(normals, faces[:, corner], areas)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    unit = areas / np.linalg.norm(areas, axis=1, keepdims=True)
    samples = np.concatenate(
        [(triangles.mean(axis=1) - step * unit)[:, None], triangles - step * normals[faces]],
        axis=1,
    )
    order = np.argsort(part, kind="stable")
    bounds = np.searchsorted(part[order], np.arange(count + 1))
    samples = samples[order].reshape(-1, 3)
    hosts = np.flatnonzero(candidate)
    pairs: list[tuple[int, int]] = []
    for host in hosts:  # a loop over parts, not faces
        # The candidate parts after this one whose bounding boxes meet this one's.
        later = hosts[hosts > host]
        meet = later[
            (low[later] <= high[host]).all(axis=1) & (low[host] <= high[later]).all(axis=1)
        ]
        if len(meet) == 0:
            continue
        host_tree = WindingTree.build(vertices, faces[order[bounds[host] : bounds[host + 1]]])
        host_points = samples[4 * bounds[host] : 4 * bounds[host + 1]]
        for guest in meet:  # a loop over pairs of parts whose boxes meet
            guest_points = samples[4 * bounds[guest] : 4 * bounds[guest + 1]]
            if (np.abs(host_tree.evaluate(guest_points)) >= 0.5).any():
                pairs.append((int(host), int(guest)))
                continue
            guest_tree = WindingTree.build(
                vertices, faces[order[bounds[guest] : bounds[guest + 1]]]
            )
            if (np.abs(guest_tree.evaluate(host_points)) >= 0.5).any():
                pairs.append((int(host), int(guest)))
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def _buried(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> int:
    """Count the faces with ``w >= 1/2`` on both sides (`faces` with parts turned outward)."""
    from shellvox.voxel.geometry import WindingTree

    triangles = vertices[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    offset = SIDE_OFFSET * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    centroids = triangles.mean(axis=1)
    points = np.concatenate([centroids + offset * normals, centroids - offset * normals])
    winding = WindingTree.build(vertices, faces).evaluate(points)
    n_faces = len(faces)
    return int(((winding[:n_faces] >= 0.5) & (winding[n_faces:] >= 0.5)).sum())
