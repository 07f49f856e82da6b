"""Topology checks and fixes: merge seams, drop degenerate faces, closed, oriented, volume.

A model must bound a volume to be printed. Seam-split vertices (UV or colour seams) are
merged by position for topology while per-corner attributes are kept; zero-area faces are
dropped with a warning (:func:`clean`); a wholly inside-out mesh is flipped with a warning;
open or non-manifold meshes are refused with the number and a location of the bad edges,
unless ``repair`` asks to close holes with a real library (trimesh, then pymeshfix), part by
part (:func:`repair_parts`: a part that would be lost is refused, never dropped silently).
``prepare(..., check="report")`` returns the merged, cleaned mesh unchecked, for ``info``.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import os
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError, opt, warn
from shellvox.model._mesh import ColouredMesh

CORNER_FIELDS = ("corner_rgba", "corner_uv")
FACE_FIELDS = ("face_rgba", "face_material")


@dataclass(frozen=True)
class EdgeReport:
    """Edge-manifold status of a triangle mesh.

    Attributes
    ----------
    boundary : (B, 2) int64
        Vertex pairs of edges used by one face only (holes).
    non_manifold : (N, 2) int64
        Vertex pairs of edges used by more than two faces.
    misoriented : (M, 2) int64
        Vertex pairs of edges whose two faces traverse them in the same direction.
    """

    boundary: NDArray[np.int64]
    non_manifold: NDArray[np.int64]
    misoriented: NDArray[np.int64]

    @property
    def closed(self) -> bool:
        """Every edge is shared by exactly two faces."""
        return len(self.boundary) == 0 and len(self.non_manifold) == 0

    @property
    def oriented(self) -> bool:
        """Every shared edge is traversed once in each direction."""
        return self.closed and len(self.misoriented) == 0


def merge_by_position(mesh: ColouredMesh) -> ColouredMesh:
    """Merge vertices with identical positions (to 1e-9 of the model size).

    Per-corner attributes (UVs, vertex colours) are unaffected, so seams keep their
    colours while the topology closes.
    """
    vertices = mesh.vertices
    extent = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 1.0
    quantum = max(extent, 1e-300) * 1e-9
    keys = np.round(vertices / quantum).astype(np.int64)
    # Group equal rows with one lexsort (much faster than np.unique(axis=0)).
    order = np.lexsort(keys.T[::-1])
    starts = np.ones(len(order), dtype=bool)
    starts[1:] = (np.diff(keys[order], axis=0) != 0).any(axis=1)
    group = np.cumsum(starts) - 1
    inverse = np.empty(len(order), dtype=np.int64)
    inverse[order] = group
    return dataclasses.replace(mesh, vertices=vertices[order[starts]], faces=inverse[mesh.faces])


def select_faces(mesh: ColouredMesh, keep: NDArray[np.bool_]) -> ColouredMesh:
    """Keep the faces where ``keep`` is true, with their attributes."""
    changes: dict[str, object] = {"faces": mesh.faces[keep]}
    for name in CORNER_FIELDS + FACE_FIELDS:
        value = getattr(mesh, name)
        if value is not None:
            changes[name] = value[keep]
    return dataclasses.replace(mesh, **changes)  # type: ignore[arg-type]


def flip(mesh: ColouredMesh) -> ColouredMesh:
    """Reverse the orientation of every face (corner attributes follow their corners)."""
    changes: dict[str, object] = {"faces": mesh.faces[:, ::-1].copy()}
    for name in CORNER_FIELDS:
        value = getattr(mesh, name)
        if value is not None:
            changes[name] = value[:, ::-1].copy()
    return dataclasses.replace(mesh, **changes)  # type: ignore[arg-type]


def edge_report(faces: NDArray[np.int64]) -> EdgeReport:
    """Classify the edges of a triangle mesh (see :class:`EdgeReport`)."""
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    ordered = np.sort(directed, axis=1)
    # One int64 key per undirected edge: a 1-D unique is much faster than unique(axis=0).
    n_vertices = int(faces.max()) + 1 if len(faces) else 1
    packed, first, inverse, counts = np.unique(
        ordered[:, 0] * n_vertices + ordered[:, 1],
        return_index=True,
        return_inverse=True,
        return_counts=True,
    )
    keys = ordered[first]
    # An edge is consistently oriented if its uses go both ways: forward - backward == 0.
    forward = (directed[:, 0] == ordered[:, 0]).astype(np.int64)
    balance = np.bincount(inverse, weights=2 * forward - 1, minlength=len(packed))
    pairs = counts == 2
    return EdgeReport(
        boundary=keys[counts == 1],
        non_manifold=keys[counts > 2],
        misoriented=keys[pairs & (balance != 0)],
    )


def signed_volume(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> float:
    """Signed volume (mm^3) by the divergence theorem; positive for outward faces."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def face_areas(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Triangle areas, ``(F,) float64`` mm^2."""
    tri = vertices[faces]
    areas: NDArray[np.float64] = 0.5 * np.linalg.norm(
        np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1
    )
    return areas


def clean(mesh: ColouredMesh) -> ColouredMesh:
    """Merge vertices by position and drop zero-area faces (with a warning).

    Nothing else is checked: the result may be open, non-manifold, inconsistently
    oriented or made of several overlapping parts.

    Raises
    ------
    InputError
        The mesh has no faces, or only zero-area ones.
    """
    path = mesh.source
    if len(mesh.faces) == 0:
        raise InputError(path, "has no faces", "export the mesh with its faces")
    mesh = merge_by_position(mesh)
    faces = mesh.faces
    extent = float(np.ptp(mesh.vertices, axis=0).max())
    repeated = (
        (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    )
    degenerate = repeated | (face_areas(mesh.vertices, faces) <= (extent * 1e-10) ** 2)
    if degenerate.all():
        raise InputError(path, "has only zero-area faces", "export a mesh that encloses a volume")
    if degenerate.any():
        warn(
            f"{path}: dropped {int(degenerate.sum())} zero-area faces",
        )
        mesh = select_faces(mesh, ~degenerate)
    return mesh


def prepare(
    mesh: ColouredMesh,
    *,
    repair: bool = False,
    check: Literal["refuse", "report"] = "refuse",
) -> ColouredMesh:
    """Merge, clean and check a mesh in millimetres; return a closed, outward mesh.

    Parameters
    ----------
    mesh : ColouredMesh
        The mesh as read, in mm.
    repair : bool, optional
        Re-orient and close the holes of each part that is not closed and oriented
        (:func:`repair_parts`), with a warning.
    check : {"refuse", "report"}, optional
        ``"refuse"``: refuse what is not a closed, oriented solid. ``"report"``: return
        the merged, cleaned (and, with `repair`, repaired) mesh as it is, open or not,
        for a report of it (:func:`shellvox.model.inspect_soup`).

    Raises
    ------
    InputError
        No faces or only zero-area ones; with ``check="refuse"`` also open,
        non-manifold, inconsistently oriented (without ``repair``) or zero-volume meshes.
    """
    path = mesh.source
    mesh = clean(mesh)
    extent = float(np.ptp(mesh.vertices, axis=0).max())
    report = edge_report(mesh.faces)
    if repair and not report.oriented:
        mesh = repair_parts(mesh)
        report = edge_report(mesh.faces)
    if check == "report":
        return mesh
    if not report.closed:
        problems = []
        for bad, what in (
            (report.boundary, "open: {n} boundary edges (holes)"),
            (report.non_manifold, "non-manifold: {n} edges shared by more than two faces"),
        ):
            if len(bad):
                x, y, z = mesh.vertices[bad[0]].mean(axis=0)
                problems.append(
                    what.format(n=len(bad)) + f", e.g. at ({x:.4g}, {y:.4g}, {z:.4g}) mm"
                )
        raise InputError(
            path,
            "; ".join(problems),
            f"close the mesh in a modeller, or pass {opt('repair')} to fill small holes",
        )
    if not report.oriented:
        where = mesh.vertices[report.misoriented[0]].mean(axis=0)
        raise InputError(
            path,
            f"inconsistently oriented: {len(report.misoriented)} edges have both faces "
            f"running the same way, e.g. at ({where[0]:.4g}, {where[1]:.4g}, {where[2]:.4g}) mm",
            f"fix the normals in a modeller, or pass {opt('repair')}",
        )
    volume = signed_volume(mesh.vertices, mesh.faces)
    if abs(volume) <= (extent * 1e-6) ** 3 or extent == 0.0:
        raise InputError(
            path,
            f"encloses no volume ({volume:.3g} mm^3)",
            "export a solid model, not a sheet or a point",
        )
    if volume < 0:
        warn(
            f"{path}: the mesh is inside out (negative volume); flipped all faces",
        )
        mesh = flip(mesh)
    return mesh


def face_parts(faces: NDArray[np.int64]) -> tuple[int, NDArray[np.int64]]:
    """Split a mesh into parts: the faces joined through shared edges.

    Parameters
    ----------
    faces : (F, 3) int64
        Triangles over vertices merged by position (:func:`merge_by_position`).

    Returns
    -------
    count : int
        The number of parts ``P``.
    part : (F,) int64
        Each face's part, ``0 .. P - 1``, numbered in the order of their first face.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n_faces = len(faces)
    if n_faces == 0:
        return 0, np.zeros(0, dtype=np.int64)
    ordered = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    n_vertices = int(faces.max()) + 1
    _, edge = np.unique(ordered[:, 0] * n_vertices + ordered[:, 1], return_inverse=True)
    # A graph of faces and edges, each face joined to its three edges: its components
    # are the parts (every edge node lies on a face, so none is a part of its own).
    size = n_faces + int(edge.max()) + 1
    rows = np.repeat(np.arange(n_faces), 3)
    graph = coo_matrix((np.ones(3 * n_faces), (rows, n_faces + edge.ravel())), (size, size))
    _, labels = connected_components(graph, directed=False)
    # Labels are given in the order nodes are first reached: faces come first.
    part = np.asarray(labels[:n_faces], dtype=np.int64)
    return int(part.max()) + 1, part


def repair_parts(mesh: ColouredMesh) -> ColouredMesh:
    """Close and orient each part of a mesh on its own; never lose a part.

    Each part (:func:`face_parts`) that is not closed and consistently oriented is
    repaired alone: trimesh makes its winding consistent and fills its one-triangle and
    one-quad holes; a part still open then goes to MeshFix (pymeshfix), alone too, since
    MeshFix keeps only the largest part of what it is given. Closed, oriented parts are
    kept as they are. A part with negative volume is turned outside out, unless it lies
    inside the rest of the model (a cavity: the generalised winding number of the other
    parts is at least 1/2 at its face centroids). New faces take the colour of the nearest
    original face. One warning line says what was done.

    Parameters
    ----------
    mesh : ColouredMesh
        Merged by position, without zero-area faces (:func:`clean`), in mm.

    Returns
    -------
    ColouredMesh
        Every part closed, consistently oriented and outward (cavities inward).

    Raises
    ------
    InputError
        One line naming each part that the repair would lose, leave with fewer than
        half its faces, or leave open (its number, face count and where it is).
    """
    count, part = face_parts(mesh.faces)
    order = np.argsort(part, kind="stable")
    bounds = np.searchsorted(part[order], np.arange(count + 1))
    pieces: list[tuple[NDArray[np.float64], NDArray[np.int64]]] = []
    failed: list[str] = []
    closed_edges, closed_parts, reoriented = 0, 0, 0
    for k in range(count):  # a loop over parts, each repaired with whole-array calls
        used, local = np.unique(mesh.faces[order[bounds[k] : bounds[k + 1]]], return_inverse=True)
        vertices, faces = mesh.vertices[used], local.reshape(-1, 3).astype(np.int64)
        report = edge_report(faces)
        if not report.oriented:
            new_vertices, new_faces = _repair_part(vertices, faces, report)
            lost = (
                "would be lost"
                if len(new_faces) == 0
                else f"would keep {len(new_faces)} faces"
                if len(new_faces) < len(faces) / 2
                else "stays open"
                if not edge_report(new_faces).closed
                else ""
            )
            if lost:
                x, y, z = vertices.mean(axis=0)
                failed.append(
                    f"part {k + 1} of {count} ({len(faces)} faces, around "
                    f"({x:.4g}, {y:.4g}, {z:.4g}) mm) {lost}"
                )
                continue
            if len(report.boundary) or len(report.non_manifold):
                closed_edges += len(report.boundary)
                closed_parts += 1
            else:
                reoriented += 1
            vertices, faces = new_vertices, new_faces
        pieces.append((vertices, faces))
    if failed:
        raise InputError(
            mesh.source,
            f"{opt('repair')} cannot repair every part: " + "; ".join(failed),
            "close or remove these parts in a modeller",
        )
    turned = _turn_outside_out(pieces)
    starts = np.cumsum([0] + [len(v) for v, _ in pieces])
    vertices = np.concatenate([v for v, _ in pieces])
    faces = np.concatenate([f + start for (_, f), start in zip(pieces, starts, strict=False)])
    done = []
    if closed_parts:
        done.append(
            f"closed {closed_edges} boundary edges in {closed_parts} of {count} parts "
            f"({len(mesh.faces)} -> {len(faces)} faces)"
        )
    if reoriented:
        done.append(f"re-oriented the faces of {reoriented} of {count} parts")
    if turned:
        done.append(
            f"turned {len(turned)} inside-out parts outside out (part "
            + ", ".join(str(k + 1) for k in turned)
            + ")"
        )
    warn(
        f"{mesh.source}: {opt('repair')} "
        + ", ".join(done)
        + "; colour of new faces is taken from the nearest original face",
    )
    return _with_geometry(mesh, vertices, faces)


def _repair_part(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], report: EdgeReport
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Make one part consistent and closed: trimesh, then MeshFix; ``(V, 3)``, ``(F, 3)``."""
    import trimesh

    candidate = trimesh.Trimesh(vertices, faces, process=False)
    if len(report.boundary) == 0 and len(report.non_manifold) == 0:
        trimesh.repair.fix_winding(candidate)  # type: ignore[no-untyped-call]
        return np.asarray(candidate.vertices), np.asarray(candidate.faces, np.int64)
    trimesh.repair.fill_holes(candidate)
    trimesh.repair.fix_winding(candidate)  # type: ignore[no-untyped-call]
    if candidate.is_watertight:
        return np.asarray(candidate.vertices), np.asarray(candidate.faces, np.int64)
    import pymeshfix

    # MeshFix prints its own lines ("could not fix everything") from C++; they are
    # not shellvox's words: the checks after the repair say what is still wrong.
    with _library_prints():
        fixed_vertices, fixed_faces = pymeshfix.clean_from_arrays(
            np.ascontiguousarray(vertices, np.float64), np.ascontiguousarray(faces, np.int32)
        )
    return np.asarray(fixed_vertices, np.float64), np.asarray(fixed_faces, np.int64).reshape(-1, 3)


def _turn_outside_out(pieces: list[tuple[NDArray[np.float64], NDArray[np.int64]]]) -> list[int]:
    """Turn the closed parts of negative volume outside out, in place; return their numbers.

    A part inside the rest (winding number of the other parts at least 1/2 at most of its
    face centroids) is a cavity and keeps its orientation.
    """
    from shellvox.voxel.geometry import fast_winding_numbers

    turned = []
    for k, (vertices, faces) in enumerate(pieces):  # a loop over parts
        if signed_volume(vertices, faces) >= 0:
            continue
        others = [(v, f) for j, (v, f) in enumerate(pieces) if j != k]
        if others:
            starts = np.cumsum([0] + [len(v) for v, _ in others])
            winding = fast_winding_numbers(
                np.concatenate([v for v, _ in others]),
                np.concatenate([f + s for (_, f), s in zip(others, starts, strict=False)]),
                vertices[faces].mean(axis=1),
            )
            if np.median(winding) >= 0.5:
                continue
        pieces[k] = (vertices, faces[:, ::-1].copy())
        turned.append(k)
    return turned


@contextlib.contextmanager
def _library_prints() -> Iterator[list[str]]:
    """Catch what a library prints on stdout and stderr, at the file descriptors.

    A compiled library writes to descriptors 1 and 2 past Python's ``sys.stdout``; for
    the block both point at a temporary file, and C's buffers are flushed before they
    are put back. Yields a list that holds the caught text (one string) after the block.
    """
    caught: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    saved = (os.dup(1), os.dup(2))
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            try:
                yield caught
            finally:
                for stream in (sys.stdout, sys.stderr):
                    stream.flush()
                _flush_c_streams()
                os.dup2(saved[0], 1)
                os.dup2(saved[1], 2)
                sink.seek(0)
                caught.append(sink.read().decode("utf-8", "replace"))
    finally:
        for fd in saved:
            os.close(fd)


def _flush_c_streams() -> None:
    """Flush the C library's stdio buffers (``fflush(NULL)``), where there is one."""
    with contextlib.suppress(OSError, AttributeError, TypeError):  # none (e.g. Windows)
        ctypes.CDLL(None).fflush(None)


def _with_geometry(
    mesh: ColouredMesh, vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> ColouredMesh:
    """Replace the geometry; each new face takes the attributes of the nearest old face."""
    from scipy.spatial import cKDTree

    old_centres = mesh.triangles.mean(axis=1)
    new_triangles = vertices[faces]
    _, nearest = cKDTree(old_centres).query(new_triangles.mean(axis=1))
    nearest = np.asarray(nearest, dtype=np.int64)
    repaired = select_faces(mesh, nearest)
    # Corner attributes follow the closest corner of the source face, so faces that were
    # only re-wound keep exactly their own UVs and colours.
    gap = new_triangles[:, :, None, :] - mesh.triangles[nearest][:, None, :, :]
    corner = np.argmin(np.einsum("nijk,nijk->nij", gap, gap), axis=2)
    rows = np.arange(len(faces))[:, None]
    changes: dict[str, object] = {
        "vertices": np.asarray(vertices, np.float64),
        "faces": np.asarray(faces, np.int64),
    }
    for name in CORNER_FIELDS:
        value = getattr(repaired, name)
        if value is not None:
            changes[name] = value[rows, corner]
    return dataclasses.replace(repaired, **changes)  # type: ignore[arg-type]
