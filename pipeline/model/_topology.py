"""Topology checks and fixes: merge seams, drop degenerate faces, closed, oriented, volume.

A model must bound a volume to be printed. Seam-split vertices (UV or colour seams) are
merged by position for topology while per-corner attributes are kept; zero-area faces are
dropped with a warning; a wholly inside-out mesh is flipped with a warning; open or
non-manifold meshes are refused with the number and a location of the bad edges, unless
``repair`` asks to close holes with a real library (trimesh, then pymeshfix), never silently.
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


def prepare(mesh: ColouredMesh, *, repair: bool = False) -> ColouredMesh:
    """Merge, clean and check a mesh in millimetres; return a closed, outward mesh.

    Raises
    ------
    InputError
        Open, non-manifold, inconsistently oriented (without ``repair``), empty or
        zero-volume meshes.
    """
    path = mesh.source
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
    report = edge_report(mesh.faces)
    if repair and not report.oriented:
        mesh = _repair(mesh, report)
        report = edge_report(mesh.faces)
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


def _repair(mesh: ColouredMesh, report: EdgeReport) -> ColouredMesh:
    """Fix winding and close holes with trimesh, falling back to pymeshfix; warn."""
    import trimesh

    candidate = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if len(report.misoriented) and not len(report.boundary) and not len(report.non_manifold):
        trimesh.repair.fix_winding(candidate)  # type: ignore[no-untyped-call]
        warn(
            f"{mesh.source}: {opt('repair')} re-oriented faces to a consistent winding",
        )
        return _with_geometry(mesh, np.asarray(candidate.vertices), np.asarray(candidate.faces))
    trimesh.repair.fill_holes(candidate)
    trimesh.repair.fix_winding(candidate)  # type: ignore[no-untyped-call]
    if not candidate.is_watertight:
        import pymeshfix

        # MeshFix prints its own lines ("could not fix everything") from C++; they are
        # not shellvox's words: the checks after the repair say what is still wrong.
        with _library_prints():
            vertices, faces = pymeshfix.clean_from_arrays(
                np.ascontiguousarray(mesh.vertices, np.float64),
                np.ascontiguousarray(mesh.faces, np.int32),
            )
        candidate = trimesh.Trimesh(vertices, faces, process=False)
    warn(
        f"{mesh.source}: {opt('repair')} closed {len(report.boundary)} boundary edges "
        f"({len(mesh.faces)} -> {len(candidate.faces)} faces); colour of new faces is "
        "taken from the nearest original face",
    )
    return _with_geometry(mesh, np.asarray(candidate.vertices), np.asarray(candidate.faces))


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
