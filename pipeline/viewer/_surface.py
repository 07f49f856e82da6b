"""The build's surface for the page's 3D view, and the opening slices, from one pass.

The surface is ``thickness.ply`` (the build's mesh, mm, with each face's layer
thicknesses), made the browser's size (:func:`browser_faces`): above :data:`MAX_FACES`
faces decimated (libigl's edge collapse), below it subdivided until its edges are about
four voxels long (trimesh), as far as the budget allows, so a large face shows the colour
patches it spans; each new face keeps the layers of the face it came from. Each face
carries:

- its colour-layer depth: the depth of the colour layers' inner boundary below the
  face (mm; the sum of the thicknesses of the layers down to the deepest colour layer);
- its colour: the sRGB of ``colour.tif`` inside the colour layers under the face's
  centre (the first of a few points along the inward normal, from the middle of the
  colour layers outwards to a couple of voxels, that falls in a colour-layer voxel);
  :data:`NO_COLOUR` where none does.

:class:`Overview` reads the z pages of the layers and the colour once (``layers.tif`` and
``colour.tif``, or level 0 of the store in blocks of its chunks' depth), in a thread, at
most :data:`PASS_BYTES` at a time (a block of pages in strips along y): it counts vivid
voxels for the opening slices (:class:`~shellvox.viewer._sections.SectionCounts`, as
``shellvox inspect`` chooses its sections) and picks up the faces' colour samples on the
way. The pass reads every page (the default model on the J750 grid, 261 pages: about a
second; spot at 100 mm, 5.8 G voxels: about 40 s from the TIFFs, 70 s from the store,
while the page shows the mid slices).

After the pass (the opening slices and the surface are ready by then), the same thread
reads the build's soft proof, ``proof.ply``, when it has one, and interpolates it at the
surface's faces (:func:`~shellvox.viewer._proof.face_proof`; 400,000 faces: about two
seconds): the predicted printed colour and its CIEDE2000 error per face.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import igl
import numpy as np
import trimesh
from numpy.typing import NDArray

from shellvox.output import read_proof_ply
from shellvox.viewer._depth import Surface
from shellvox.viewer._folder import BuildFolder
from shellvox.viewer._proof import FaceProof, face_proof
from shellvox.viewer._sections import SectionCounts

#: Faces sent to the browser at most (about 44 bytes each: 18 MB).
MAX_FACES = 400_000
#: Memory of the pages the pass reads at once, bytes (a block of z pages in y strips).
PASS_BYTES = 1 << 28

#: sRGB of a face under which no colour-layer voxel was found.
NO_COLOUR = (160, 160, 160)


@dataclass(frozen=True)
class SurfaceMesh:
    """The surface as the page draws it: triangles, per-face colour and depth.

    Parameters
    ----------
    triangles_mm : (F, 3, 3) float32, mm
        Corners ``(x, y, z)`` of each face, outward-facing order.
    srgb : (F, 3) uint8
        Face colour (sRGB codes).
    depth_mm : (F,) float32, mm
        Colour-layer depth of each face.
    source_faces : int
        Faces of ``thickness.ply`` (``F`` is smaller when it was decimated).
    """

    triangles_mm: NDArray[np.float32]
    srgb: NDArray[np.uint8]
    depth_mm: NDArray[np.float32]
    source_faces: int

    def to_bytes(self) -> bytes:
        """Return the triangles, the depths and the colours back to back (little-endian)."""
        return b"".join(
            (
                np.ascontiguousarray(self.triangles_mm, "<f4").tobytes(),
                np.ascontiguousarray(self.depth_mm, "<f4").tobytes(),
                np.ascontiguousarray(self.srgb, np.uint8).tobytes(),
            )
        )

    def headers(self) -> dict[str, str]:
        """HTTP headers describing :meth:`to_bytes`."""
        top = float(self.depth_mm.max()) if len(self.depth_mm) else 1.0
        return {
            "X-Faces": str(len(self.depth_mm)),
            "X-Source-Faces": str(self.source_faces),
            "X-Depth-Range": f"0,{top if top > 0 else 1.0!r}",
        }


def colour_depths(
    surface: Surface, colour_layers: tuple[int, ...]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return each face's colour-layer depth and the depth of the colour layers' middle.

    Parameters
    ----------
    surface : Surface
        ``thickness_mm`` is ``(K, F)``: layer ``k + 1``'s thickness on each face.
    colour_layers : tuple of int
        Indices (1..K) of the colour layers.

    Returns
    -------
    depth_mm, middle_mm : (F,) float64, mm
    """
    limits = np.cumsum(surface.thickness_mm, axis=0)  # (K, F) inner boundary of each layer
    layers = [k for k in colour_layers if 1 <= k <= surface.n_layers] or [1]
    first, last = min(layers), max(layers)
    top = limits[first - 2] if first >= 2 else np.zeros(limits.shape[1])
    return limits[last - 1], (top + limits[last - 1]) / 2


def browser_faces(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    edge_mm: float,
    max_faces: int = MAX_FACES,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Return the mesh with at most `max_faces` faces, and each face's source face.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
    edge_mm : float, mm
        Below `max_faces`, edges longer than this (or than the budget allows) are split.
    max_faces : int
        Above this, the mesh is decimated.

    Returns
    -------
    vertices : (V', 3) float64, mm
    faces : (F', 3) int64
    source : (F',) int64
        The face of the input each face came from.
    """
    if len(faces) <= max_faces:
        corners = vertices[faces]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        area = float(np.linalg.norm(normals, axis=1).sum() / 2)
        edge = max(edge_mm, float(np.sqrt(2.5 * area / max_faces)))
        for _ in range(4):  # a face is about edge**2 / 2.3: double the edge if over budget
            finer = trimesh.remesh.subdivide_to_size(  # type: ignore[no-untyped-call]
                vertices, faces, edge, max_iter=8, return_index=True
            )
            if len(finer[1]) <= max_faces:
                return np.asarray(finer[0]), np.asarray(finer[1], np.int64), np.asarray(finer[2])
            edge *= 2
        return vertices, faces, np.arange(len(faces), dtype=np.int64)
    try:
        new_vertices, new_faces, source, _ = igl.decimate(
            np.asfortranarray(vertices, np.float64), np.asfortranarray(faces, np.int32), max_faces
        )
    except (RuntimeError, ValueError):
        new_faces = np.zeros((max_faces + 1, 3), np.int64)
    if len(new_faces) <= max_faces and len(new_faces):
        return np.asarray(new_vertices), np.asarray(new_faces, np.int64), np.asarray(source)
    keep = np.linspace(0, len(faces) - 1, max_faces).astype(np.int64)  # not a manifold
    return vertices, faces[keep], keep


class _Samples:
    """Candidate voxels for the faces' colours, sorted by page."""

    def __init__(self, folder: BuildFolder, triangles: NDArray[np.float64], middle_mm: Any) -> None:
        edge_a = triangles[:, 1] - triangles[:, 0]
        edge_b = triangles[:, 2] - triangles[:, 0]
        normals = np.cross(edge_a, edge_b)
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
        centres = triangles.mean(axis=1)
        voxel = float(max(folder.grid.voxel_mm))
        steps = [np.asarray(middle_mm) * s for s in (1.0, 0.5, 1.5)]
        steps += [np.full(len(centres), voxel * s) for s in (0.5, 1.0, 2.0)]
        points = np.concatenate([centres - normals * d[:, None] for d in steps])  # (K * F, 3)
        index = np.rint(folder.grid.world_to_index(points)).astype(np.int64)
        shape = np.asarray(folder.grid.shape_zyx)
        self.valid = np.all((index >= 0) & (index < shape), axis=1)
        index = np.clip(index, 0, shape - 1)
        self.n_faces = len(centres)
        self.n_candidates = len(steps)
        self.order = np.argsort(index[:, 0], kind="stable")
        self.index = index[self.order]
        self.page_start = np.searchsorted(self.index[:, 0], np.arange(shape[0] + 1))
        self.layer = np.zeros(len(points), np.uint8)
        self.rgb = np.zeros((len(points), 3), np.uint8)

    def take(self, z: int, layers: NDArray[np.uint8], rgb: NDArray[np.uint8], y0: int = 0) -> None:
        """Read the candidates on page `z`, or on its rows from `y0` on (``(n, X)``)."""
        a, b = self.page_start[z], self.page_start[z + 1]
        if a == b:
            return
        at = self.order[a:b]
        y, x = self.index[a:b, 1] - y0, self.index[a:b, 2]
        here = (y >= 0) & (y < len(layers))
        at, y, x = at[here], y[here], x[here]
        self.layer[at] = layers[y, x]
        self.rgb[at] = rgb[y, x, :3]

    def colours(self, colour_layers: tuple[int, ...]) -> NDArray[np.uint8]:
        """Each face's colour: its first candidate in a colour layer."""
        hit = np.isin(self.layer, colour_layers) & self.valid
        hit = hit.reshape(self.n_candidates, self.n_faces)
        first = np.argmax(hit, axis=0)
        faces = np.arange(self.n_faces)
        rgb: NDArray[np.uint8] = self.rgb.reshape(self.n_candidates, self.n_faces, 3)[first, faces]
        rgb[~hit.any(axis=0)] = NO_COLOUR
        return rgb


def _strip_rows(block_zyx: tuple[int, int, int], voxel_bytes: int, row_block: int) -> int:
    """Return the rows of a strip of a block of pages within :data:`PASS_BYTES`.

    A multiple of `row_block` (the chunks' rows), at least one of them; all rows if they fit.

    >>> _strip_rows((64, 2000, 1000), 4, 64), _strip_rows((64, 100, 10**6), 4, 64)
    (1024, 64)
    """
    n_z, n_y, n_x = block_zyx
    fit = PASS_BYTES // max(1, n_z * n_x * voxel_bytes)
    if fit >= n_y:
        return n_y
    return max(row_block, fit // row_block * row_block)


class Overview:
    """One pass over the z pages, in a thread: the opening slices and the surface.

    Then, in the same thread, the soft proof at the surface's faces (see the module).

    Parameters
    ----------
    folder : BuildFolder
        The open build (its stacks are read concurrently with the server's requests).
    max_faces : int
        Decimate the surface above this many faces.

    Attributes
    ----------
    opening, vivid, surface, error
        Set by the pass, before :attr:`done`.
    proof : FaceProof or None
        The soft proof at the faces of :attr:`surface`, set before :attr:`proof_done`;
        None without a surface, without ``proof.ply``, or when it cannot be read
        (:attr:`proof_error` says why).
    """

    def __init__(self, folder: BuildFolder, max_faces: int = MAX_FACES) -> None:
        self.folder = folder
        self.max_faces = max_faces
        self.opening: dict[str, int] | None = None
        self.vivid: dict[str, int] | None = None
        self.surface: SurfaceMesh | None = None
        self.error: str | None = None
        self.proof: FaceProof | None = None
        self.proof_error: str | None = None
        self.done = threading.Event()
        self.proof_done = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="overview", daemon=True)

    def start(self) -> None:
        """Begin the pass."""
        self._thread.start()

    def close(self) -> None:
        """Stop the pass (between blocks of pages) and wait for it."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        try:
            try:
                self._scan()
            except (OSError, ValueError) as error:
                self.error = str(error)
            finally:
                self.done.set()
            self._proof()
        finally:
            self.proof_done.set()

    def _proof(self) -> None:
        """Interpolate ``proof.ply`` at the surface's faces (see the module)."""
        path = self.folder.files.get("proof.ply")
        if path is None or self.surface is None or self._stop.is_set():
            return
        try:
            self.proof = face_proof(read_proof_ply(path), self.surface.triangles_mm)
        except (OSError, ValueError) as error:
            self.proof_error = f"{path.name} cannot be read: {error}"

    def _scan(self) -> None:
        folder = self.folder
        colour_layers = tuple(layer.index for layer in folder.layers if layer.colour)
        n_z, n_y, n_x = folder.grid.shape_zyx
        counts = SectionCounts((n_z, n_y, n_x), colour_layers)
        samples = mesh = None
        if folder.surface is not None:
            mesh = self._mesh(folder.surface, colour_layers)
            samples = _Samples(folder, mesh[0], mesh[1])
        layer_stack, colour_stack = folder.stacks["layers"], folder.stacks["colour"]
        block = max(layer_stack.page_block, colour_stack.page_block)  # chunks decoded once
        strip = _strip_rows(
            (block, n_y, n_x),
            1 + colour_stack.pixel_bytes,
            max(layer_stack.row_block, colour_stack.row_block),
        )
        for z0 in range(0, n_z, block):
            z1 = min(n_z, z0 + block)
            for y0 in range(0, n_y, strip):
                if self._stop.is_set():
                    return
                y1 = min(n_y, y0 + strip)
                layer_pages = layer_stack.pages(z0, z1, y0, y1)
                colour_pages = colour_stack.pages(z0, z1, y0, y1)
                for z in range(z0, z1):
                    layers, rgb = layer_pages[z - z0], colour_pages[z - z0]
                    counts.add_page(z, layers, rgb, y0)
                    if samples is not None:
                        samples.take(z, layers, rgb, y0)
        self.opening = counts.chosen()
        self.vivid = {axis: int(counts.vivid[axis][i]) for axis, i in self.opening.items()}
        if samples is not None and mesh is not None:
            self.surface = SurfaceMesh(
                mesh[0].astype(np.float32),
                samples.colours(colour_layers),
                mesh[2].astype(np.float32),
                len(folder.surface.index.faces) if folder.surface else 0,
            )

    def _mesh(
        self, surface: Surface, colour_layers: tuple[int, ...]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Outward triangles ``(F, 3, 3)``, their colour layers' middle and depth (mm)."""
        depth, middle = colour_depths(surface, colour_layers)
        vertices, faces, source = browser_faces(
            surface.index.vertices,
            surface.index.faces,
            edge_mm=4 * max(self.folder.grid.voxel_mm),
            max_faces=self.max_faces,
        )
        triangles = vertices[faces]
        volume = np.einsum("ij,ij->", triangles[:, 0], np.cross(triangles[:, 1], triangles[:, 2]))
        if volume < 0:  # inward-facing: turn every face
            triangles = triangles[:, ::-1]
        return np.ascontiguousarray(triangles), middle[source], depth[source]

    def opening_json(self) -> dict[str, Any]:
        """Return the answer of ``/api/opening`` (JSON-ready)."""
        if not self.done.is_set():
            return {"ready": False}
        return {"ready": True, "slices": self.opening, "vivid": self.vivid, "error": self.error}
