"""``shellvox view``'s server on a real build, checked against tifffile, trimesh, colour-science.

The server runs in a thread on a free port; requests go through http.client, which
sends paths as written (``..`` and ``%2e`` reach the server unchanged).
"""

from __future__ import annotations

import http.client
import json
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import colour
import numpy as np
import pytest
import tifffile
import trimesh
from viewer_run import serving

from shellvox.cli import main
from shellvox.errors import InputError
from shellvox.viewer import STATIC, BuildFolder

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def server(small_colour_build):
    with serving(small_colour_build) as viewer:
        yield viewer


@pytest.fixture(scope="module")
def truth(small_colour_build):
    """The build as independent readers see it: stacks, manifest, surface."""
    folder = small_colour_build
    mesh = trimesh.load(folder / "thickness.ply", process=False, force="mesh")
    return {
        "layers": tifffile.imread(folder / "layers.tif"),
        "colour": tifffile.imread(folder / "colour.tif"),
        "materials": tifffile.imread(folder / "materials.tif"),
        "manifest": json.loads((folder / "manifest.json").read_text()),
        "mesh": mesh,
        "face_thickness": np.asarray(mesh.metadata["_ply_raw"]["face"]["data"]["thickness"]),
    }


def get(server, path, host=None, method="GET"):
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    headers = {"Host": host} if host else {}
    connection.request(method, path, headers=headers)
    response = connection.getresponse()
    body = response.read()
    connection.close()
    return response.status, dict(response.getheaders()), body


def slice_array(server, kind, axis, index, rows, cols):
    query = (
        f"kind={kind}&axis={axis}&index={index}&r0={rows.start}&r1={rows.stop}&rs={rows.step}"
        f"&c0={cols.start}&c1={cols.stop}&cs={cols.step}"
    )
    status, headers, body = get(server, "/api/slice?" + query)
    assert status == 200, body
    shape = tuple(int(n) for n in headers["X-Shape"].split(","))
    return np.frombuffer(body, dtype=np.dtype(headers["X-Dtype"]).newbyteorder("<")).reshape(shape)


def brute_nearest(mesh, points):
    """Distance to every face (trimesh's closest point per triangle), the nearest kept."""
    triangles = mesh.triangles
    distances = np.empty((len(points), len(triangles)))
    for i, point in enumerate(points):
        repeated = np.repeat(point[None], len(triangles), axis=0)
        closest = trimesh.triangles.closest_point(triangles, repeated)
        distances[i] = np.linalg.norm(closest - point, axis=1)
    return distances


@pytest.mark.parametrize("kind", ["layers", "colour", "materials"])
@pytest.mark.parametrize(
    ("axis", "index", "rows", "cols"),
    [
        ("z", 20, range(0, 200, 1), range(0, 200, 1)),
        ("y", 40, range(3, 60, 2), range(0, 200, 3)),
        ("x", 60, range(0, 60, 1), range(10, 70, 4)),
    ],
)
def test_slices_are_the_stacks(server, truth, kind, axis, index, rows, cols):
    volume = truth[kind]
    n = volume.shape["zyx".index(axis)]
    index = min(index, n - 1)
    plane = volume[(slice(None),) * "zyx".index(axis) + (index,)]
    got = slice_array(server, kind, axis, index, rows, cols)
    rows = range(rows.start, min(rows.stop, plane.shape[0]), rows.step)
    cols = range(cols.start, min(cols.stop, plane.shape[1]), cols.step)
    expected = plane[np.ix_(list(rows), list(cols))]
    np.testing.assert_array_equal(got.reshape(expected.shape), expected)


def test_depth_is_the_distance_to_the_surface(server, truth):
    grid = truth["manifest"]["grid"]
    n_bands = len(truth["manifest"]["layers"]) - 2
    z = grid["shape_zyx"][0] // 2
    got = slice_array(server, "depth", "z", z, range(0, 10**6), range(0, 10**6))
    layers = truth["layers"][z]
    band = (layers >= 1) & (layers <= n_bands)
    assert np.array_equal(~np.isnan(got[..., 0]), band)  # depth exactly on the bands
    rng = np.random.default_rng(0)
    ys, xs = np.nonzero(band)
    pick = rng.choice(len(ys), 60, replace=False)
    points = np.asarray(grid["origin_mm"]) + np.stack(
        [xs[pick], ys[pick], np.full(60, z)], axis=1
    ) * np.asarray(grid["voxel_size_mm"])
    distances = brute_nearest(truth["mesh"], points)
    nearest = distances.min(axis=1)
    np.testing.assert_allclose(got[ys[pick], xs[pick], 0], nearest, atol=1e-5)  # float32
    for i in range(60):  # the thickness of a face at that distance (ties: any of them)
        tied = distances[i] <= nearest[i] + 1e-9
        assert np.isclose(got[ys[pick[i]], xs[pick[i]], 1], truth["face_thickness"][tied]).any()


def test_voxel_read_out(server, truth):
    manifest = truth["manifest"]
    grid = manifest["grid"]
    names = {m["index"]: m["name"] for m in manifest["materials"]}
    colour_layers = {layer["index"] for layer in manifest["layers"] if layer["colour"]}
    rng = np.random.default_rng(1)
    layers = truth["layers"]
    picks = [np.argwhere(layers == k) for k in range(len(manifest["layers"]))]
    voxels = [p[rng.integers(len(p))] for p in picks for _ in range(3)]
    for z, y, x in voxels:
        status, _, body = get(server, f"/api/voxel?z={z}&y={y}&x={x}")
        assert status == 200
        readout = json.loads(body)
        centre = np.asarray(grid["origin_mm"]) + np.array([x, y, z]) * grid["voxel_size_mm"]
        np.testing.assert_allclose(readout["position_mm"], centre, atol=1e-12)
        assert readout["layer"]["index"] == layers[z, y, x]
        assert readout["layer"]["name"] == manifest["layers"][layers[z, y, x]]["name"]
        assert readout["material"]["name"] == names[truth["materials"][z, y, x]]
        if layers[z, y, x] in colour_layers:
            rgb = truth["colour"][z, y, x, :3]
            assert readout["colour"]["srgb"] == rgb.tolist()
            lab = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(rgb / 255.0))
            # scikit-image (the server) and colour-science round the sRGB matrix and the
            # D65 white differently: up to about 0.015 apart, far below a visible difference
            np.testing.assert_allclose(readout["colour"]["lab"], lab, atol=0.05)
        else:
            assert readout["colour"] is None
        nearest = brute_nearest(truth["mesh"], centre[None])[0].min()
        assert readout["depth"]["mm"] == pytest.approx(nearest, abs=1e-9)
        assert readout["depth"]["inside"] == (layers[z, y, x] != 0)


def test_the_page_and_its_files_are_served_from_the_package(server):
    for name, kind in STATIC.items():
        status, headers, body = get(server, f"/static/{name}")
        assert status == 200 and headers["Content-Type"] == kind
        assert body == (REPO / "pipeline" / "viewer" / "static" / name).read_bytes()
        assert b"://" not in body  # nothing loaded from elsewhere
    status, _, body = get(server, "/")
    assert status == 200 and b'src="/static/viewer.js"' in body
    status, _, body = get(server, "/api/build")
    assert (
        json.loads(body)["grid"]["shape_zyx"]
        == json.loads(get(server, "/files/manifest.json")[2])["grid"]["shape_zyx"]
    )


@pytest.mark.parametrize(
    "path",
    [
        "/files/../manifest.json",
        "/files/../../../../etc/passwd",
        "/files/%2e%2e/%2e%2e/etc/passwd",
        "/files/%2E%2E%2Fmanifest.json",
        "/static/../viewer.py",
        "/static/..%2f..%2fserver.py",
        "/files//etc/passwd",
        "//etc/passwd",
        "/etc/passwd",
        "/files/layers.tif",  # a build file, but not one handed out
        "/files/.shellvox.lock",
        "/files/manifest.json/",
        "/files/./manifest.json",
        "/api/../files/manifest.json",
    ],
)
def test_paths_out_of_the_table_are_not_found(server, path):
    status, _, body = get(server, path)
    assert status == 404, (path, body)


def test_requests_for_another_host_and_writes_are_refused(server):
    assert get(server, "/api/build", host="example.com")[0] == 403
    assert get(server, "/api/build", host=f"127.0.0.1:{server.port + 1}")[0] == 403
    assert get(server, "/api/build", host=f"localhost:{server.port}")[0] == 200
    assert get(server, "/api/build", method="POST")[0] == 405


@pytest.mark.parametrize(
    ("query", "message"),
    [
        ("kind=layers&axis=w&index=0&r0=0&r1=5&rs=1&c0=0&c1=5&cs=1", "axis"),
        ("kind=layers&axis=z&index=999999&r0=0&r1=5&rs=1&c0=0&c1=5&cs=1", "outside"),
        ("kind=layers&axis=z&index=0&r0=0&r1=5&rs=0&c0=0&c1=5&cs=1", "rs must be"),
        ("kind=layers&axis=z&index=0&r0=0&r1=5&rs=1&c0=0&c1=5", "give one cs"),
        ("kind=layers&axis=z&index=x&r0=0&r1=5&rs=1&c0=0&c1=5&cs=1", "integer"),
        ("kind=secrets&axis=z&index=0&r0=0&r1=5&rs=1&c0=0&c1=5&cs=1", "kind"),
    ],
)
def test_bad_requests_say_why(server, query, message):
    status, _, body = get(server, "/api/slice?" + query)
    assert status == 400 and message in body.decode()
    assert get(server, "/api/voxel?z=0&y=0&x=99999")[0] == 400
    assert get(server, "/api/voxel?z=0&y=0")[0] == 400


def _copy(build, tmp_path):
    copy = tmp_path / "build"
    shutil.copytree(build, copy)
    return copy


def _relist(folder, name, data):
    import hashlib

    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["files"][name] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    (folder / "manifest.json").write_text(json.dumps(manifest))


def _symlink_out(folder):
    outside = folder.parent / "elsewhere.ply"
    shutil.copy(folder / "thickness.ply", outside)
    (folder / "thickness.ply").unlink()
    (folder / "thickness.ply").symlink_to(outside)


def _garbage_stack(folder):
    data = b"II*\0" + bytes(range(256)) * 20
    (folder / "colour.tif").write_bytes(data)
    _relist(folder, "colour.tif", data)


CASES = {
    "no manifest": (lambda f: (f / "manifest.json").unlink(), "no manifest.json"),
    "manifest not JSON": (lambda f: (f / "manifest.json").write_text("{"), "not valid JSON"),
    "missing stack": (lambda f: (f / "layers.tif").unlink(), "layers.tif: is missing"),
    "truncated stack": (
        lambda f: (f / "colour.tif").write_bytes((f / "colour.tif").read_bytes()[:999]),
        "colour.tif: has 999 bytes",
    ),
    "stack a folder": (
        lambda f: ((f / "layers.tif").unlink(), (f / "layers.tif").mkdir()),
        "not a regular file",
    ),
    "file linked out of the folder": (_symlink_out, "outside the folder"),
    "stack that is no TIFF, listed": (_garbage_stack, "a stack cannot be read"),
    "thickness.ply damaged, listed": (
        lambda f: (
            (f / "thickness.ply").write_bytes(b"ply\nformat ascii 1.0\nend_header\n"),
            _relist(f, "thickness.ply", b"ply\nformat ascii 1.0\nend_header\n"),
        ),
        "thickness.ply: cannot be read",
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_a_folder_that_is_not_a_complete_build_is_refused(
    small_colour_build, tmp_path, capsys, case
):
    folder = _copy(small_colour_build, tmp_path)
    damage, message = CASES[case]
    damage(folder)
    assert main(["view", str(folder), "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("shellvox: error: ") and message in err, err
    with pytest.raises(InputError):
        BuildFolder.open(folder)


def test_not_a_folder_and_a_bad_port_are_refused(tmp_path, capsys, small_colour_build):
    assert main(["view", str(tmp_path / "nothing")]) == 2
    assert "is not a folder" in capsys.readouterr().err
    assert main(["view", str(tmp_path)]) == 2
    assert "no manifest.json" in capsys.readouterr().err
    assert main(["view", str(small_colour_build), "--port", "70000"]) == 2
    assert "--port" in capsys.readouterr().err


def test_view_command_serves_until_interrupted(small_colour_build):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    process = subprocess.Popen(
        [sys.executable, "-m", "shellvox.cli", "view", str(small_colour_build)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        line = process.stdout.readline()
        assert line.startswith("shellvox view: ") and "http://127.0.0.1:" in line, line
        url = line.split(" at ")[1].split()[0]
        port = int(url.rsplit(":", 1)[1].strip("/"))
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        connection.request("GET", "/api/build")
        assert connection.getresponse().status == 200
        connection.close()
    finally:
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=30)
    assert process.returncode == 0, err
    assert "stopped" in err and "Traceback" not in err


def test_a_client_that_resets_its_connection_is_no_error(server, capsys):
    """A page closed mid-conversation (TCP reset on a kept-alive connection) prints nothing."""
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as sock:
        host = f"127.0.0.1:{server.port}".encode()
        sock.sendall(b"GET /api/build HTTP/1.1\r\nHost: " + host + b"\r\n\r\n")
        assert sock.recv(12) == b"HTTP/1.1 200"
        # Close with a reset (linger 0) while the server awaits the next request.
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    time.sleep(0.5)
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    connection.request("GET", "/api/build")
    assert connection.getresponse().status == 200  # still serving
    connection.close()
    assert "Traceback" not in capsys.readouterr().err
