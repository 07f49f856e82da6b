"""The soft proof the viewer sends per face, against proof.ply read by trimesh.

- ``/api/proof`` over HTTP: face for face with ``/api/surface``, each face's predicted
  sRGB, CIEDE2000 error and gamut error equal to the stored proof interpolated at its
  centre (``read_proof_ply(...).at``), and to a brute-force interpolation of proof.ply as
  trimesh reads it, by the rule the manifest records, converted with colour-science;
- a build without proof.ply has no proof to send (404), and a proof.ply that cannot be
  read leaves the surface intact (503 with the reason);
- :func:`face_proof` on shapes it refuses and faces no sample faces;
- the ΔE scale ``/api/build`` sends is the soft-proof picture's (:mod:`shellvox.voxel.io`),
  and the page's files hold none of its colours (they take the server's).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from viewer_run import http_get, lab_to_srgb8, proof_reference, serving

from shellvox.output import PROOF_FILE, read_proof_ply
from shellvox.viewer import STATIC, BuildFolder, de_scale, face_proof
from shellvox.voxel.io import DE_RGB, DE_STEPS, HATCH_RGB, NO_PREDICTION_RGB, de_colours

STATIC_DIR = Path(__file__).resolve().parents[2] / "pipeline" / "viewer" / "static"


def _faces(server):
    """The surface and the proof the server sends, decoded as the module docstrings say."""
    status, headers, body = http_get(server, "/api/surface")
    assert status == 200
    n = int(headers["X-Faces"])
    triangles = np.frombuffer(body, "<f4", 9 * n).reshape(n, 3, 3).astype(np.float64)
    target = np.frombuffer(body, np.uint8, 3 * n, offset=40 * n).reshape(n, 3)
    status, proof_headers, proof_body = http_get(server, "/api/proof")
    assert status == 200, proof_body
    assert int(proof_headers["X-Faces"]) == n
    assert len(proof_body) == 11 * n
    sent = {
        "total_de": np.frombuffer(proof_body, "<f4", n),
        "gamut_de": np.frombuffer(proof_body, "<f4", n, offset=4 * n),
        "srgb": np.frombuffer(proof_body, np.uint8, 3 * n, offset=8 * n).reshape(n, 3),
        "headers": proof_headers,
    }
    return triangles, target, sent


def test_the_proof_sent_per_face_is_the_stored_proof_at_the_faces(small_colour_build):
    folder = small_colour_build
    manifest = json.loads((folder / "manifest.json").read_text())
    with serving(folder) as server:
        triangles, target, sent = _faces(server)
    assert sent["headers"]["X-Optics"] == manifest["proof"]["optics"]
    assert float(sent["headers"]["X-In-Gamut-DE"]) == manifest["proof"]["in_gamut_de"]
    centres = triangles.mean(axis=1)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])

    # every face: the stored proof, interpolated by the package at the face
    stored = read_proof_ply(folder / PROOF_FILE).at(centres, normals)
    np.testing.assert_array_equal(sent["total_de"], stored.total_de.astype(np.float32))
    np.testing.assert_array_equal(sent["gamut_de"], stored.gamut_de.astype(np.float32))
    np.testing.assert_array_equal(sent["srgb"], stored.srgb("predicted"))

    # some faces: a brute-force interpolation of proof.ply as trimesh reads it
    cloud = trimesh.load(folder / PROOF_FILE)
    raw = cloud.metadata["_ply_raw"]["vertex"]["data"]
    sample_lab = np.column_stack([raw[f"predicted_{c}"] for c in "Lab"])
    reference = proof_reference(
        folder / PROOF_FILE, centres[:1], normals[:1], manifest["proof"]["interpolation"]
    )
    # the file's point colours are its predicted CIELAB in sRGB (colour-science)
    sample_srgb = lab_to_srgb8(sample_lab, reference["white_xy"])
    assert np.abs(sample_srgb - cloud.colors[:, :3].astype(int)).max() <= 1
    some = np.random.default_rng(3).choice(len(centres), min(800, len(centres)), replace=False)
    reference = proof_reference(
        folder / PROOF_FILE, centres[some], normals[some], manifest["proof"]["interpolation"]
    )
    assert reference["optics"] == sent["headers"]["X-Optics"]
    for name in ("total_de", "gamut_de"):
        np.testing.assert_allclose(sent[name][some], reference[name], rtol=1e-5, atol=1e-4)
    srgb = lab_to_srgb8(reference["predicted_lab"], reference["white_xy"])
    assert np.abs(sent["srgb"][some].astype(int) - srgb).max() <= 1

    # the proof is there and says something: predicted on nearly every face, not the
    # model's colour, and both in and out of gamut
    known = np.isfinite(sent["total_de"])
    assert known.mean() > 0.99
    assert np.median(sent["total_de"][known]) > 1.0
    assert np.mean(np.abs(sent["srgb"].astype(int) - target).max(axis=1) > 10) > 0.3
    out = sent["gamut_de"][known] > manifest["proof"]["in_gamut_de"]
    assert 0.05 < out.mean() < 0.95


def test_a_build_without_a_readable_proof(small_colour_build, tmp_path):
    # proof.ply that is not one (the size the manifest records): the surface still comes
    broken = tmp_path / "broken"
    shutil.copytree(small_colour_build, broken)
    data = bytearray((broken / PROOF_FILE).read_bytes())
    data[:4] = b"xyz\n"
    (broken / PROOF_FILE).write_bytes(bytes(data))
    with serving(broken) as server:
        assert json.loads(http_get(server, "/api/build")[2])["proof"] is True
        assert http_get(server, "/api/surface")[0] == 200
        status, _, body = http_get(server, "/api/proof")
        assert status == 503
        assert b"proof.ply cannot be read: is not a PLY file" in body
    # no proof.ply (a build without materials or a colour report): nothing to send
    without = tmp_path / "without"
    shutil.copytree(small_colour_build, without)
    manifest = json.loads((without / "manifest.json").read_text())
    del manifest["files"][PROOF_FILE], manifest["proof"]
    (without / "manifest.json").write_text(json.dumps(manifest))
    (without / PROOF_FILE).unlink()
    with serving(without) as server:
        assert json.loads(http_get(server, "/api/build")[2])["proof"] is False
        assert http_get(server, "/api/surface")[0] == 200
        status, _, body = http_get(server, "/api/proof")
        assert status == 404
        assert b"no soft proof (proof.ply" in body
        assert http_get(server, f"/files/{PROOF_FILE}")[0] == 404
        assert server.overview.proof_done.wait(30)
        assert server.overview.proof is None and server.overview.proof_error is None


def test_face_proof_refuses_other_shapes_and_leaves_unfaced_faces_grey(small_colour_build):
    proof = read_proof_ply(small_colour_build / PROOF_FILE)
    with pytest.raises(ValueError, match=r"triangles_mm must be \(F, 3, 3\), got \(2, 3\)"):
        face_proof(proof, np.zeros((2, 3)))
    centre = proof.points_mm[0]
    a, b = np.linalg.svd(proof.normals[:1])[2][1:]  # two directions across the normal
    face = centre + 0.01 * np.array([a - b, b, -a])  # centred on the sample
    if np.cross(face[1] - face[0], face[2] - face[0]) @ proof.normals[0] < 0:
        face = face[::-1]  # facing the sample's normal
    out = face_proof(proof, np.stack([face, face[::-1], np.repeat(centre[None], 3, axis=0)]))
    # its own side: the sample's neighbourhood; the other side and no area: no prediction
    assert np.isfinite(out.total_de[0]) and np.isnan(out.total_de[1:]).all()
    assert out.predicted_srgb[1:].tolist() == [[160, 160, 160]] * 2
    assert out.total_de.dtype == np.float32 and out.predicted_srgb.dtype == np.uint8
    assert out.optics == proof.optics
    with BuildFolder.open(small_colour_build) as folder:
        assert folder.describe()["proof"] is True
        assert folder.files[PROOF_FILE] == (small_colour_build / PROOF_FILE).resolve()


def test_the_delta_e_scale_sent_is_the_soft_proof_pictures(small_colour_build):
    with serving(small_colour_build) as server:
        status, _, body = http_get(server, "/api/build")
    assert status == 200
    scale = json.loads(body)["de_scale"]
    assert scale == de_scale()
    steps = scale["steps"]
    assert [step["low"] for step in steps] == list(DE_STEPS)
    assert [step["high"] for step in steps] == [*DE_STEPS[1:], None]
    assert [step["label"] for step in steps] == ["0-1", "1-2", "2-3", "3-5", "5-10", ">= 10"]
    assert [step["srgb"] for step in steps] == DE_RGB.tolist()
    # each step's colour is the picture's for errors from its lower bound to just below
    # its upper one
    for step in steps:
        high = step["high"] if step["high"] is not None else 1e3
        values = np.array([step["low"], (step["low"] + high) / 2, np.nextafter(high, 0.0)])
        assert de_colours(values).tolist() == [step["srgb"]] * 3, step
    assert scale["no_prediction_srgb"] == list(NO_PREDICTION_RGB)
    assert de_colours(np.array([np.nan])).tolist() == [scale["no_prediction_srgb"]]
    assert scale["hatch_srgb"] == list(HATCH_RGB)
    assert isinstance(scale["hatch_period_px"], int) and scale["hatch_period_px"] >= 2

    # the page's files do not write the scale's colours themselves
    for name in STATIC:
        text = (STATIC_DIR / name).read_text(encoding="utf-8").lower()
        for r, g, b in [*DE_RGB.tolist(), NO_PREDICTION_RGB, HATCH_RGB]:
            written = [rf"\b{r},\s*{g},\s*{b}\b", f"#{r:02x}{g:02x}{b:02x}"]
            assert not any(re.search(pattern, text) for pattern in written), (name, r, g, b)
