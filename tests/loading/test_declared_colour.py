"""Declared colour reaches the surface: MeshLab-style MTL, glTF factors in linear light.

Expected colours come from colour-science's sRGB transfer functions and from the file
contents, not from shellvox.
"""

from __future__ import annotations

import base64
import json
import warnings

import colour
import numpy as np
import pytest
from builders import (
    CORNER_UV,
    TET_FACES,
    TET_VERTICES,
    glb_bytes,
    gltf_parts,
    locate,
    marker_image,
    png_bytes,
)
from corpus_files import obj_text, write_gltf

from shellvox.config import LoadOptions
from shellvox.errors import ShellvoxWarning
from shellvox.loading import load_model

WIDTH, HEIGHT, ROW, COL = 64, 32, 8, 10
RED = [255, 0, 0, 255]


def _srgb8(linear) -> np.ndarray:
    """Linear light in [0, 1] to sRGB 0-255 by colour-science."""
    return np.rint(colour.cctf_encoding(np.asarray(linear, float), function="sRGB") * 255)


def _linear(srgb8) -> np.ndarray:
    return colour.cctf_decoding(np.asarray(srgb8, float) / 255, function="sRGB")


def _colour_at_uv(mesh, uv):
    """Colour at the point of face 0 whose interpolated UV (v up) is ``uv``."""
    corners = CORNER_UV[0]
    b1, b2 = (np.asarray(uv) - corners[0]) / 0.9
    point = np.array([1 - b1 - b2, b1, b2]) @ TET_VERTICES[TET_FACES[0]]
    face, bary = locate(mesh, point)
    return mesh.colour_at(face, bary)[0].tolist()


def _centroid_colours(mesh) -> np.ndarray:
    rows = []
    for face in TET_FACES:
        fid, bary = locate(mesh, TET_VERTICES[face].mean(0))
        rows.append(mesh.colour_at(fid, bary)[0])
    return np.array(rows)


U, V_UP = (COL + 0.5) / WIDTH, 1 - (ROW + 0.5) / HEIGHT


def test_meshlab_mtl_with_tabs_and_spaces_finds_the_texture(tmp_path):
    text = obj_text().replace("mtllib model.mtl", "mtllib\tmodel.mtl\t")
    text = text.replace("usemtl painted", "usemtl\tpainted\t\t").replace("\nf ", "\nf\t")
    (tmp_path / "model.obj").write_text(text)
    (tmp_path / "model.mtl").write_text(
        "newmtl\tpainted\t\t\nKa\t1 1 1\nKd\t1 1 1\nmap_Kd\tmy  texture file.png\n"
    )
    (tmp_path / "my  texture file.png").write_bytes(
        png_bytes(marker_image(WIDTH, HEIGHT, ROW, COL))
    )
    mesh = load_model(tmp_path / "model.obj")
    assert mesh.colour_kind == "texture"
    assert _colour_at_uv(mesh, [U, V_UP]) == RED


def test_mtl_clamp_option_and_unused_material_with_missing_texture(tmp_path):
    (tmp_path / "model.obj").write_text(obj_text())
    (tmp_path / "model.mtl").write_text(
        "newmtl painted\nmap_Kd -clamp on tex.png\nnewmtl unused\nmap_Kd gone.png\n"
    )
    (tmp_path / "tex.png").write_bytes(png_bytes(marker_image(WIDTH, HEIGHT, ROW, COL)))
    mesh = load_model(tmp_path / "model.obj")  # 'unused' is never read: no error
    assert [m.wrap for m in mesh.materials] == [("clamp", "clamp")]


def test_undefined_material_gets_the_colour_option(tmp_path):
    (tmp_path / "model.obj").write_text(obj_text(uv=False, material="nowhere"))
    (tmp_path / "model.mtl").write_text("newmtl other\nKd 1 0 0\n")
    with pytest.warns(ShellvoxWarning, match="'nowhere'"):
        mesh = load_model(tmp_path / "model.obj", LoadOptions(colour=(10, 20, 30, 255)))
    assert (_centroid_colours(mesh) == [10, 20, 30, 255]).all()


@pytest.mark.parametrize("uv", [True, False])
@pytest.mark.parametrize("factor", [[0.5, 0.2, 1.0, 1.0], [0.0, 0.001, 0.9, 1.0]])
def test_gltf_factor_without_texture_is_linear(tmp_path, factor, uv):
    document, binary = gltf_parts(factor=factor)
    if not uv:
        del document["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
    path = tmp_path / "f.glb"
    path.write_bytes(glb_bytes(document, binary))
    mesh = load_model(path)
    expected = np.append(_srgb8(factor[:3]), 255)
    np.testing.assert_array_equal(_centroid_colours(mesh), np.tile(expected, (4, 1)))
    if factor[0] == 0.5:
        assert expected[0] == 188  # not 128: the factor is linear light


def test_gltf_factor_times_texture_in_linear_light(tmp_path):
    texel = np.array([90, 160, 30])
    factor = np.array([0.5, 0.8, 0.3, 1.0])
    image = np.zeros((4, 4, 4), np.uint8)
    image[..., :3] = texel
    image[..., 3] = 255
    uri = "data:image/png;base64," + base64.b64encode(png_bytes(image)).decode()
    path = write_gltf(tmp_path, *gltf_parts(image={"uri": uri}, factor=factor.tolist()))
    mesh = load_model(path)
    assert mesh.colour_kind == "texture"
    expected = np.append(_srgb8(_linear(texel) * factor[:3]), 255)
    np.testing.assert_array_equal(_centroid_colours(mesh), np.tile(expected, (4, 1)))


def _with_colour_0(document, binary, values, component_type):
    """Add a COLOR_0 accessor (12 corners) to the primitive of a :func:`gltf_parts` file."""
    blob = values.tobytes()
    document["bufferViews"].append(
        {"buffer": 0, "byteOffset": len(binary), "byteLength": len(blob)}
    )
    binary += blob + b"\0" * (-len(blob) % 4)
    document["buffers"][0]["byteLength"] = len(binary)
    accessor = {"bufferView": len(document["bufferViews"]) - 1, "count": 12, "type": "VEC4"}
    accessor["componentType"] = component_type
    if component_type != 5126:
        accessor["normalized"] = True
    document["accessors"].append(accessor)
    primitive = document["meshes"][0]["primitives"][0]
    primitive["attributes"]["COLOR_0"] = len(document["accessors"]) - 1
    return document, binary


@pytest.mark.parametrize("component_type", [5126, 5121])
def test_gltf_color_0_times_factor(tmp_path, component_type):
    rng = np.random.default_rng(1)
    per_vertex = np.concatenate([rng.uniform(0.05, 1, (4, 3)), np.ones((4, 1))], 1)
    corners = per_vertex[TET_FACES.reshape(-1)]
    if component_type == 5121:
        stored = np.rint(corners * 255).astype(np.uint8)
        linear = stored / 255.0
    else:
        stored = corners.astype(np.float32)
        linear = stored.astype(np.float64)
    factor = [0.9, 0.5, 0.7, 1.0]
    path = tmp_path / "c.glb"
    path.write_bytes(glb_bytes(*_with_colour_0(*gltf_parts(factor=factor), stored, component_type)))
    mesh = load_model(path)
    assert mesh.colour_kind == "vertex"
    expected = _srgb8(linear[:, :3] * factor[:3]).reshape(4, 3, 3)
    for f in range(4):
        for c in range(3):
            got = mesh.colour_at(np.array([f]), np.eye(3)[c][None])[0, :3]
            corner = mesh.vertices[mesh.faces[f, c]]
            original = [
                (g, k)
                for g in range(4)
                for k in range(3)
                if np.allclose(TET_VERTICES[TET_FACES[g, k]], corner, atol=1e-4)  # float32 m
            ]
            # A merged vertex's corners all carry the same colour in this file.
            np.testing.assert_array_equal(got, expected[original[0]])


def test_gltf_missing_image_with_colour_gives_that_colour(tmp_path):
    path = write_gltf(tmp_path, *gltf_parts(image={"uri": "gone.png"}))
    with pytest.warns(ShellvoxWarning, match="'gone.png'"):
        mesh = load_model(path, LoadOptions(colour=(10, 20, 30, 255)))
    np.testing.assert_array_equal(_centroid_colours(mesh), np.tile([10, 20, 30, 255], (4, 1)))


def test_gltf_instances_and_mirroring_node_keep_faces_outward(tmp_path):
    document, binary = gltf_parts(factor=[1, 0, 0, 1])
    document["nodes"] = [
        {"mesh": 0, "translation": [0.02, 0, 0]},  # metres, glTF's unit
        {"mesh": 0, "scale": [-1, 1, 1]},
    ]
    document["scenes"] = [{"nodes": [0, 1]}]
    path = tmp_path / "two.glb"
    path.write_bytes(glb_bytes(document, binary))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an inside-out part would be flipped with a warning
        mesh = load_model(path)
    assert mesh.n_faces == 8
    xs = np.sort(np.unique(mesh.vertices[:, 0]))
    np.testing.assert_allclose(xs, [-10, 0, 20, 30], atol=1e-5)  # float32 metres, in mm
    volume = (
        np.einsum(
            "fi,fi->f", mesh.triangles[:, 0], np.cross(*mesh.triangles[:, 1:].swapaxes(0, 1))
        ).sum()
        / 6
    )
    assert volume == pytest.approx(2 * 1000 / 6)


def test_gltf_document_is_not_changed_on_disk(tmp_path):
    path = write_gltf(tmp_path, *gltf_parts(factor=[0.5, 0.5, 0.5, 1]))
    before = path.read_bytes()
    load_model(path)
    assert path.read_bytes() == before
    assert json.loads(before)["materials"][0]["name"] == "painted"


def test_gltf_primitives_keep_their_own_materials(tmp_path):
    document, binary = gltf_parts(factor=[1, 0, 0, 1])
    # Split the index accessor (12 uint32) in two primitives of two faces each.
    document["accessors"][2]["count"] = 6
    document["accessors"].append(
        {"bufferView": 2, "byteOffset": 24, "componentType": 5125, "count": 6, "type": "SCALAR"}
    )
    document["materials"].append(
        {"name": "blue", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0.2, 1]}}
    )
    first = document["meshes"][0]["primitives"][0]
    second = {"attributes": dict(first["attributes"]), "indices": 3, "material": 1}
    document["meshes"][0]["primitives"].append(second)
    path = tmp_path / "two.glb"
    path.write_bytes(glb_bytes(document, binary))
    mesh = load_model(path)
    blue = np.append(_srgb8([0, 0, 0.2]), 255)
    expected = np.array([[255, 0, 0, 255]] * 2 + [blue] * 2)
    np.testing.assert_array_equal(_centroid_colours(mesh), expected)
