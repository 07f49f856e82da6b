"""colour_at against independent truth: file contents, format specs, colour-science."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from builders import (
    TET_FACES,
    TET_VERTICES,
    locate,
    marker_image,
    write_3mf,
    write_glb,
    write_obj,
)

from shellvox.config import LoadOptions
from shellvox.loading import load_model

WIDTH, HEIGHT, ROW, COL = 64, 32, 8, 10
RED = [255, 0, 0, 255]
# Face corners' UVs: a right triangle covering most of the image.
CORNERS = np.array([[0.05, 0.05], [0.95, 0.05], [0.05, 0.95]])
CORNER_UV = np.tile(CORNERS, (4, 1, 1))


def _point_for_uv(uv: np.ndarray) -> np.ndarray:
    """Point on face 0 of the tetrahedron whose interpolated UV is ``uv``."""
    b1, b2 = (uv - CORNERS[0]) / 0.9
    bary = np.array([1 - b1 - b2, b1, b2])
    return bary @ TET_VERTICES[TET_FACES[0]]


def _colour_at_point(mesh, point):
    face, bary = locate(mesh, point)
    return mesh.colour_at(face, bary)[0].tolist()


# Texel (ROW, COL) centre: u = (COL + .5) / W; row counted from the top of the picture.
U = (COL + 0.5) / WIDTH
V_TOP = (ROW + 0.5) / HEIGHT  # glTF: v grows downwards from the top-left origin
V_UP = 1.0 - V_TOP  # OBJ and 3MF: v grows upwards from the bottom-left origin


def test_obj_texture_marker_lands_on_expected_point(tmp_path):
    write_obj(tmp_path / "m.obj", CORNER_UV, marker_image(WIDTH, HEIGHT, ROW, COL))
    mesh = load_model(tmp_path / "m.obj")
    assert mesh.colour_kind == "texture"
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_UP]))) == RED
    # With v flipped the marker would be elsewhere: that point is not red.
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_TOP]))) != RED


@pytest.mark.parametrize("palette", [False, True])
def test_glb_texture_marker_uses_top_left_origin(tmp_path, palette):
    write_glb(tmp_path / "m.glb", CORNER_UV, marker_image(WIDTH, HEIGHT, ROW, COL), palette=palette)
    mesh = load_model(tmp_path / "m.glb")
    assert mesh.colour_kind == "texture"
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_TOP]))) == RED
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_UP]))) != RED


def test_glb_base_colour_factor_multiplies_in_linear_light(tmp_path):
    write_glb(
        tmp_path / "m.glb",
        CORNER_UV,
        marker_image(WIDTH, HEIGHT, ROW, COL),
        factor=[0.5, 1.0, 1.0, 1.0],
    )
    mesh = load_model(tmp_path / "m.glb")
    got = _colour_at_point(mesh, _point_for_uv(np.array([U, V_TOP])))
    expected_red = round(float(colour.cctf_encoding(0.5, function="sRGB")) * 255)
    assert got == [expected_red, 0, 0, 255]


def test_3mf_texture_marker_uses_bottom_left_origin(tmp_path):
    write_3mf(
        tmp_path / "m.3mf", texture=marker_image(WIDTH, HEIGHT, ROW, COL), corner_uv=CORNER_UV
    )
    mesh = load_model(tmp_path / "m.3mf")
    assert mesh.colour_kind == "texture"
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_UP]))) == RED


def test_3mf_in_centimetres_comes_out_in_millimetres(tmp_path):
    write_3mf(tmp_path / "cm.3mf", unit="centimeter")
    mesh = load_model(tmp_path / "cm.3mf")
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [100.0, 100.0, 100.0])


def test_units_and_scale_options_apply_to_unitless_formats(tmp_path):
    write_obj(tmp_path / "m.obj", CORNER_UV, marker_image(WIDTH, HEIGHT, ROW, COL))
    inch = load_model(tmp_path / "m.obj", LoadOptions(units="inch", scale=2.0))
    np.testing.assert_allclose(np.ptp(inch.vertices, axis=0), [508.0, 508.0, 508.0])


def test_3mf_vertex_colours_match_the_xml(tmp_path):
    colours = ["#FF0000", "#00FF00", "#0000FF", "#FFFFFF80"]
    index = np.array([[0, 1, 2], [3, 2, 1], [0, 0, 0], [1, 1, 3]])
    write_3mf(tmp_path / "c.3mf", colours=colours, corner_colour_index=index)
    mesh = load_model(tmp_path / "c.3mf")
    rgba = np.array([list(bytes.fromhex(c[1:] + ("FF" if len(c) == 7 else ""))) for c in colours])
    for f, face in enumerate(TET_FACES):
        for corner in range(3):
            # The corner of face f: locate the face containing the centroid, then the corner.
            fid, _ = locate(mesh, TET_VERTICES[face].mean(0))
            local = int(
                np.flatnonzero(
                    (mesh.vertices[mesh.faces[fid[0]]] == TET_VERTICES[face[corner]]).all(1)
                )[0]
            )
            bary = np.eye(3)[local][None]
            assert mesh.colour_at(fid, bary)[0].tolist() == rgba[index[f, corner]].tolist()


@pytest.mark.parametrize(
    "name", ["3mf/pyramid_vertexcolor.3mf", "3mf/rhombicuboctahedron_color.3mf"]
)
def test_shared_3mf_colours_match_lib3mf(shared_mesh, name):
    import lib3mf

    path = shared_mesh(name)
    mesh = load_model(path)
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    objects = model.GetMeshObjects()
    checked = 0
    while objects.MoveNext():
        obj = objects.GetCurrentMeshObject()
        vertices = np.array(
            [list(obj.GetVertex(i).Coordinates) for i in range(obj.GetVertexCount())]
        )
        for t in range(obj.GetTriangleCount()):
            corners = list(obj.GetTriangle(t).Indices)
            props = obj.GetTriangleProperties(t)
            group = model.GetColorGroupByID(props.ResourceID)
            fid, _ = locate(mesh, vertices[corners].mean(0))
            for c in range(3):
                expected = group.GetColor(list(props.PropertyIDs)[c])
                local = int(
                    np.flatnonzero(
                        np.isclose(mesh.vertices[mesh.faces[fid[0]]], vertices[corners[c]]).all(1)
                    )[0]
                )
                got = mesh.colour_at(fid, np.eye(3)[local][None])[0].tolist()
                assert got == [expected.Red, expected.Green, expected.Blue, expected.Alpha]
                checked += 1
    assert checked == 3 * len(mesh.faces)


def _ply_vertex_table(path):
    """Parse the airplane's binary PLY with numpy (header layout read from the file)."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    assert "property uchar red" in header and "property double quality" in header
    count = int(header.split("element vertex ")[1].split()[0])
    dtype = np.dtype(
        [
            ("x", "<f8"),
            ("y", "<f8"),
            ("z", "<f8"),
            ("r", "u1"),
            ("g", "u1"),
            ("b", "u1"),
            ("a", "u1"),
            ("q", "<f8"),
        ]
    )
    table = np.frombuffer(data, dtype=dtype, count=count, offset=end)
    xyz = np.stack([table["x"], table["y"], table["z"]], 1)
    rgba = np.stack([table["r"], table["g"], table["b"], table["a"]], 1)
    return xyz, rgba


def test_ply_vertex_colours_exact_at_corners_and_linear_between(shared_mesh):
    path = shared_mesh("airplane/colored_airplane.ply")
    mesh = load_model(path)
    xyz, rgba = _ply_vertex_table(path)
    lookup = {tuple(p): tuple(c) for p, c in zip(xyz.tolist(), rgba.tolist(), strict=True)}
    rng = np.random.default_rng(1)
    faces = rng.choice(len(mesh.faces), 300, replace=False)
    for corner in range(3):
        got = mesh.colour_at(faces, np.tile(np.eye(3)[corner], (300, 1)))
        expected = [lookup[tuple(p)] for p in mesh.vertices[mesh.faces[faces, corner]].tolist()]
        np.testing.assert_array_equal(got, expected)
    # Mid-point of edge 0-1: the mean in linear light, encoded (colour-science's sRGB).
    a = np.array([lookup[tuple(p)] for p in mesh.vertices[mesh.faces[faces, 0]].tolist()])
    b = np.array([lookup[tuple(p)] for p in mesh.vertices[mesh.faces[faces, 1]].tolist()])
    linear = (
        colour.cctf_decoding(a[:, :3] / 255, function="sRGB")
        + colour.cctf_decoding(b[:, :3] / 255, function="sRGB")
    ) / 2
    expected_rgb = np.rint(colour.cctf_encoding(linear, function="sRGB") * 255)
    got = mesh.colour_at(faces, np.tile([0.5, 0.5, 0.0], (300, 1)))
    np.testing.assert_array_equal(got[:, :3], expected_rgb)


def test_obj_vertex_colours_from_v_lines(shared_mesh):
    path = shared_mesh("cube-vertexcolor/cube_with_vertexcolors.obj")
    mesh = load_model(path)
    rows = [line.split()[1:] for line in path.read_text().splitlines() if line.startswith("v ")]
    table = {
        tuple(map(float, r[:3])): [round(float(c) * 255) for c in r[3:6]] + [255] for r in rows
    }
    for f in range(len(mesh.faces)):
        for c in range(3):
            got = mesh.colour_at(np.array([f]), np.eye(3)[c][None])[0].tolist()
            assert got == table[tuple(mesh.vertices[mesh.faces[f, c]].tolist())]


def test_obj_materials_without_texture_give_face_colours(tmp_path):
    lines = ["mtllib m.mtl"] + [f"v {x} {y} {z}" for x, y, z in TET_VERTICES]
    for i, face in enumerate(TET_FACES):
        lines += [
            f"usemtl {'warm' if i % 2 else 'cold'}",
            "f " + " ".join(str(v + 1) for v in face),
        ]
    (tmp_path / "m.obj").write_text("\n".join(lines))
    (tmp_path / "m.mtl").write_text("newmtl warm\nKd 1 0.5 0\nnewmtl cold\nKd 0 0 1\n")
    mesh = load_model(tmp_path / "m.obj")
    assert mesh.colour_kind == "face"
    got = {tuple(c) for c in mesh.face_rgba.tolist()}
    assert got == {(255, 128, 0, 255), (0, 0, 255, 255)}


@pytest.mark.parametrize("map_kd", ["textures\\my tex.png", "-s 1 1 1 textures/my tex.png"])
def test_obj_texture_paths_with_spaces_and_backslashes(tmp_path, map_kd):
    (tmp_path / "textures").mkdir()
    write_obj(
        tmp_path / "m.obj",
        CORNER_UV,
        marker_image(WIDTH, HEIGHT, ROW, COL),
        map_kd=map_kd,
        image_name="textures/my tex.png",
    )
    mesh = load_model(tmp_path / "m.obj")
    assert mesh.colour_kind == "texture"
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_UP]))) == RED


def test_obj_without_mtl_takes_texture_option(tmp_path):
    write_obj(
        tmp_path / "m.obj",
        CORNER_UV,
        marker_image(WIDTH, HEIGHT, ROW, COL),
        write_mtl=False,
        image_name="given.png",
    )
    with pytest.warns(UserWarning, match="MTL file"):
        mesh = load_model(tmp_path / "m.obj", LoadOptions(texture=tmp_path / "given.png"))
    assert mesh.colour_kind == "texture"
    assert _colour_at_point(mesh, _point_for_uv(np.array([U, V_UP]))) == RED


PLY_HEADER = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"


def test_ply_float_vertex_colours(tmp_path):
    colours = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.7, 0.9]])
    text = PLY_HEADER + "property float z\nproperty float red\nproperty float green\n"
    text += "property float blue\nelement face 4\nproperty list uchar int vertex_indices\n"
    text += "end_header\n"
    text += "".join(
        f"{x} {y} {z} {r} {g} {b}\n"
        for (x, y, z), (r, g, b) in zip(TET_VERTICES, colours, strict=True)
    )
    text += "".join(f"3 {a} {b} {c}\n" for a, b, c in TET_FACES)
    (tmp_path / "f.ply").write_text(text)
    mesh = load_model(tmp_path / "f.ply")
    assert mesh.colour_kind == "vertex"
    expected = np.rint(colours * 255)
    for f in range(4):
        for c in range(3):
            got = mesh.colour_at(np.array([f]), np.eye(3)[c][None])[0]
            vertex = int(
                np.flatnonzero((mesh.vertices[mesh.faces[f, c]] == TET_VERTICES).all(1))[0]
            )
            np.testing.assert_array_equal(got[:3], expected[vertex])


def test_ply_uchar_face_colours(tmp_path):
    colours = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9]])
    text = PLY_HEADER + "property float z\nelement face 4\n"
    text += "property list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
    text += "property uchar blue\nend_header\n"
    text += "".join(f"{x} {y} {z}\n" for x, y, z in TET_VERTICES)
    text += "".join(
        f"3 {a} {b} {c} {r} {g} {bl}\n"
        for (a, b, c), (r, g, bl) in zip(TET_FACES, colours, strict=True)
    )
    (tmp_path / "fc.ply").write_text(text)
    mesh = load_model(tmp_path / "fc.ply")
    assert mesh.colour_kind == "face"
    for f, face in enumerate(TET_FACES):
        fid, bary = locate(mesh, TET_VERTICES[face].mean(0))
        np.testing.assert_array_equal(mesh.colour_at(fid, bary)[0, :3], colours[f])


def test_glb_color_0_is_linear_light_encoded_to_srgb(tmp_path):
    rng = np.random.default_rng(7)
    linear = np.concatenate([rng.uniform(0.05, 1.0, (4, 3)), np.ones((4, 1))], axis=1)
    corner = linear[TET_FACES.reshape(-1)]  # one colour per tetrahedron vertex
    write_glb(tmp_path / "c.glb", None, None, corner_colour_linear=corner)
    mesh = load_model(tmp_path / "c.glb")
    assert mesh.colour_kind == "vertex"
    expected = colour.cctf_encoding(linear[:, :3], function="sRGB") * 255
    for f in range(4):
        for c in range(3):
            got = mesh.colour_at(np.array([f]), np.eye(3)[c][None])[0, :3]
            # the file holds metres as float32: the corner in mm within 1e-4 mm
            near = np.isclose(mesh.vertices[mesh.faces[f, c]], TET_VERTICES, atol=1e-4)
            vertex = int(np.flatnonzero(near.all(1))[0])
            # COLOR_0 passes through 8-bit linear storage in trimesh: allow that rounding.
            np.testing.assert_allclose(got, expected[vertex], atol=3)


def test_obj_with_two_textured_materials_keeps_them_distinct(tmp_path):
    lines = ["mtllib m.mtl"] + [f"v {x} {y} {z}" for x, y, z in TET_VERTICES]
    lines += ["vt 0.5 0.5"]
    for i, face in enumerate(TET_FACES):
        lines += [f"usemtl {'a' if i < 2 else 'b'}", "f " + " ".join(f"{v + 1}/1" for v in face)]
    (tmp_path / "m.obj").write_text("\n".join(lines))
    (tmp_path / "m.mtl").write_text("newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\n")
    from builders import png_bytes

    for name, value in (("a", (200, 10, 10)), ("b", (10, 10, 200))):
        image = np.zeros((4, 4, 4), np.uint8)
        image[..., :3] = value
        image[..., 3] = 255
        (tmp_path / f"{name}.png").write_bytes(png_bytes(image))
    mesh = load_model(tmp_path / "m.obj")
    assert mesh.colour_kind == "texture"
    assert len(mesh.materials) == 2
    for f, face in enumerate(TET_FACES):
        fid, bary = locate(mesh, TET_VERTICES[face].mean(0))
        want = (200, 10, 10) if f < 2 else (10, 10, 200)
        assert tuple(mesh.colour_at(fid, bary)[0, :3]) == want
