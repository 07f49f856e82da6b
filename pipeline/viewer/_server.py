"""The viewer's web server: the standard library's threaded HTTP server on 127.0.0.1.

Routes (GET and HEAD only; anything else is 404 or 405):

- ``/`` and ``/static/NAME``: the page (HTML, JavaScript, CSS shipped as the resources of
  ``shellvox.viewer.static``, read once at start; nothing is fetched from elsewhere).
- ``/api/build``: the grid, layers, materials and stacks, and the ΔE mode's scale under
  ``de_scale`` (:func:`~shellvox.viewer._proof.de_scale`) (JSON).
- ``/api/slice?kind=K&axis=A&index=I&r0=&r1=&rs=&c0=&c1=&cs=``: a slice region
  (:mod:`shellvox.viewer._slices`) as raw bytes, row-major, with its shape in the
  ``X-Shape`` header (``H,W,S``) and its dtype in ``X-Dtype`` (``uint8`` or
  ``float32``, little-endian).
- ``/api/voxel?z=&y=&x=``: one voxel's read-out (JSON).
- ``/api/opening?wait=S``: the slice to open on each axis, the one with the most vivid
  colour-layer voxels (:mod:`shellvox.viewer._surface`): ``{"ready": false}`` until the
  pass over the pages is done, waiting up to ``S`` seconds (0..30) for it.
- ``/api/surface``: the surface for the 3D view, once the pass is done
  (:meth:`~shellvox.viewer._surface.SurfaceMesh.to_bytes`; ``X-Faces``,
  ``X-Source-Faces`` and ``X-Depth-Range`` headers); 404 without ``thickness.ply``.
- ``/api/proof``: the soft proof at the same faces, in their order, once it is
  interpolated (:meth:`~shellvox.viewer._proof.FaceProof.to_bytes`: each face's
  CIEDE2000 error and gamut error, float32, then its predicted sRGB; ``X-Faces``,
  ``X-Optics`` (``assumed`` or ``measured``) and ``X-In-Gamut-DE`` headers); 404 without
  ``thickness.ply`` or ``proof.ply`` (a build without materials or a colour report),
  503 when ``proof.ply`` cannot be read.
- ``/files/NAME``: ``manifest.json``, ``thickness.ply`` and ``proof.ply`` as they are.

A request path is never joined to a folder: every name is looked up in a table made
when the server starts (the static files, and the build's files by the paths fixed when
it was opened), so ``..``, absolute paths, encoded dots and links lead nowhere. Requests
must name the server itself in ``Host`` (127.0.0.1 or localhost with its port), which
keeps other web pages from reading the build through the browser (DNS rebinding).
"""

from __future__ import annotations

import json
import sys
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import parse_qs, unquote, urlsplit

import numpy as np

from shellvox.viewer._folder import BuildFolder
from shellvox.viewer._proof import de_scale
from shellvox.viewer._slices import (
    KINDS,
    RequestError,
    SliceRegion,
    probe,
    read_region,
)
from shellvox.viewer._stacks import StackError
from shellvox.viewer._surface import Overview

#: Longest wait of a request for the pass over the pages (s).
SURFACE_WAIT_S = 600.0

#: The page's files: name -> content type.
STATIC = {
    "index.html": "text/html; charset=utf-8",
    "viewer.js": "text/javascript; charset=utf-8",
    "surface.js": "text/javascript; charset=utf-8",
    "viewer.css": "text/css; charset=utf-8",
}

_FILE_TYPES = {".json": "application/json", ".ply": "application/octet-stream"}


def static_files() -> dict[str, bytes]:
    """Return the page's files, read from the package (they ship inside it)."""
    folder = resources.files("shellvox.viewer") / "static"
    return {name: (folder / name).read_bytes() for name in STATIC}


class ViewerServer(ThreadingHTTPServer):
    """A threaded HTTP server showing one open build.

    Parameters
    ----------
    folder : BuildFolder
        The build (closed by :meth:`server_close`).
    port : int
        TCP port on 127.0.0.1; 0 picks a free one (see :attr:`url`).
    warm : bool
        Decode the pages of whole-model y and x slices in the background
        (:meth:`BuildFolder.warm_in_background`).
    overview : bool
        Start the pass over the pages that finds the opening slices and colours the
        surface (:class:`~shellvox.viewer._surface.Overview`); without it
        ``/api/opening`` and ``/api/surface`` never become ready.
    """

    daemon_threads = True

    def __init__(
        self, folder: BuildFolder, port: int = 0, *, warm: bool = True, overview: bool = True
    ) -> None:
        self.folder = folder
        self.static = static_files()
        build = {**folder.describe(), "de_scale": de_scale()}
        self.build_json = json.dumps(build).encode("utf-8")
        self.overview = Overview(folder)
        super().__init__(("127.0.0.1", port), _Handler)
        if overview:
            self.overview.start()
        if warm:
            folder.warm_in_background()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server_address[1])

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://127.0.0.1:{self.port}/"

    def server_close(self) -> None:
        """Stop listening and close the build."""
        super().server_close()
        self.overview.close()
        self.folder.close()

    def handle_error(self, request: Any, client_address: Any) -> None:
        """Let a browser go away quietly; print anything else (socketserver's default).

        A client that closes its connection while a reply is written or the next
        request awaited (a page closed, a slice superseded) is not an error.
        """
        error = sys.exc_info()[1]
        if isinstance(error, (ConnectionResetError, BrokenPipeError, ConnectionAbortedError)):
            return
        super().handle_error(request, client_address)


class _Handler(BaseHTTPRequestHandler):
    server: ViewerServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:
        """Stay quiet: the terminal shows the address, not every request."""

    def do_HEAD(self) -> None:
        """Answer like GET, without the body."""
        self._serve(head=True)

    def do_GET(self) -> None:
        """Route the request (see the module docstring)."""
        self._serve(head=False)

    def do_POST(self) -> None:
        """Refuse: the viewer only reads."""
        self._send(HTTPStatus.METHOD_NOT_ALLOWED, b"GET only\n", "text/plain", head=False)

    def _serve(self, *, head: bool) -> None:
        host = self.headers.get("Host", "")
        allowed = {f"127.0.0.1:{self.server.port}", f"localhost:{self.server.port}"}
        if host not in allowed:
            self._send(HTTPStatus.FORBIDDEN, b"wrong Host\n", "text/plain", head=head)
            return
        parts = urlsplit(self.path)
        path = unquote(parts.path)
        query = parse_qs(parts.query, keep_blank_values=True)
        try:
            if path in ("/", "/index.html"):
                self._send(
                    HTTPStatus.OK, self.server.static["index.html"], STATIC["index.html"], head=head
                )
            elif path.startswith("/static/") and path[8:] in self.server.static:
                name = path[8:]
                self._send(HTTPStatus.OK, self.server.static[name], STATIC[name], head=head)
            elif path == "/api/build":
                self._send(HTTPStatus.OK, self.server.build_json, "application/json", head=head)
            elif path == "/api/slice":
                self._slice(query, head=head)
            elif path == "/api/voxel":
                self._voxel(query, head=head)
            elif path == "/api/opening":
                self._opening(query, head=head)
            elif path == "/api/surface":
                self._surface(head=head)
            elif path == "/api/proof":
                self._proof(head=head)
            elif path.startswith("/files/") and path[7:] in self.server.folder.files:
                file = self.server.folder.files[path[7:]]
                kind = _FILE_TYPES.get(file.suffix, "application/octet-stream")
                self._send(HTTPStatus.OK, file.read_bytes(), kind, head=head)
            else:
                self._send(HTTPStatus.NOT_FOUND, b"not found\n", "text/plain", head=head)
        except RequestError as error:
            self._send(HTTPStatus.BAD_REQUEST, f"{error}\n".encode(), "text/plain", head=head)
        except (StackError, OSError) as error:
            message = f"the build cannot be read: {error}\n".encode()
            self._send(HTTPStatus.INTERNAL_SERVER_ERROR, message, "text/plain", head=head)

    def _slice(self, query: dict[str, list[str]], *, head: bool) -> None:
        started = time.perf_counter()
        kind = (query.get("kind") or [""])[0]
        if kind not in KINDS:
            raise RequestError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        folder = self.server.folder
        region = SliceRegion.from_query(query, folder.grid.shape_zyx)
        values = read_region(folder, kind, region)
        shape = values.shape if values.ndim == 3 else (*values.shape, 1)
        body = np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<")).tobytes()
        headers = {
            "X-Shape": ",".join(str(n) for n in shape),
            "X-Dtype": str(values.dtype),
            "X-Region": region.header(),
            "X-Seconds": f"{time.perf_counter() - started:.4f}",
        }
        self._send(HTTPStatus.OK, body, "application/octet-stream", head=head, headers=headers)

    def _voxel(self, query: dict[str, list[str]], *, head: bool) -> None:
        index = []
        for name in ("z", "y", "x"):
            values = query.get(name) or [""]
            if len(values) != 1 or not values[0].isdigit() or len(values[0]) > 12:
                raise RequestError(f"{name} must be one non-negative integer")
            index.append(int(values[0]))
        body = json.dumps(probe(self.server.folder, *index)).encode("utf-8")
        self._send(HTTPStatus.OK, body, "application/json", head=head)

    def _opening(self, query: dict[str, list[str]], *, head: bool) -> None:
        values = query.get("wait") or ["0"]
        try:
            wait = float(values[0]) if len(values) == 1 else -1.0
        except ValueError:
            wait = -1.0
        if not 0 <= wait <= 30:
            raise RequestError("wait must be one number of seconds, 0 to 30")
        self.server.overview.done.wait(wait)
        body = json.dumps(self.server.overview.opening_json()).encode("utf-8")
        self._send(HTTPStatus.OK, body, "application/json", head=head)

    def _surface(self, *, head: bool) -> None:
        overview = self.server.overview
        if self.server.folder.surface is None:
            message = b"this build has no thickness.ply (built with --thickness): no surface\n"
            self._send(HTTPStatus.NOT_FOUND, message, "text/plain", head=head)
            return
        ready = overview.done.wait(SURFACE_WAIT_S)
        self._send_made("the surface", overview.surface if ready else None, overview.error, head)

    def _proof(self, *, head: bool) -> None:
        overview = self.server.overview
        folder = self.server.folder
        if folder.surface is None or "proof.ply" not in folder.files:
            message = (
                b"this build has no soft proof (proof.ply: made by builds with materials and a"
                b" colour report) or no surface (thickness.ply): no predicted colour\n"
            )
            self._send(HTTPStatus.NOT_FOUND, message, "text/plain", head=head)
            return
        ready = overview.proof_done.wait(SURFACE_WAIT_S)
        error = overview.proof_error or overview.error
        self._send_made("the soft proof", overview.proof if ready else None, error, head)

    def _send_made(self, what: str, made: Any, error: str | None, head: bool) -> None:
        """Send what the overview's pass made (its bytes), or why it is not ready (503)."""
        if made is None:
            why = f"{what} is not ready ({error or 'still reading'})\n"
            self._send(HTTPStatus.SERVICE_UNAVAILABLE, why.encode(), "text/plain", head=head)
            return
        body = made.to_bytes()
        self._send(
            HTTPStatus.OK, body, "application/octet-stream", head=head, headers=made.headers()
        )

    def _send(
        self,
        status: HTTPStatus,
        body: bytes,
        content_type: str,
        *,
        head: bool,
        headers: dict[str, str] | None = None,
    ) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        for key, value in (headers or {}).items():
            self.send_header(key, value)
        self.end_headers()
        if not head:
            self.wfile.write(body)
