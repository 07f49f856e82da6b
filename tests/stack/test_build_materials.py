"""Issue 10 end to end: adaptive depth in the voxels, materials, the .gcvf job, translucency.

Every check reads the written files back with an independent reader (tifffile, zipfile +
ElementTree, Pillow) and compares them with each other or with what the rule and the
separation say.
"""

from __future__ import annotations

import io
import json
import re
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
import tifffile
import trimesh
from PIL import Image

from shellvox.cli import main
from shellvox.config import BuildConfig, MaterialSettings
from shellvox.model import ColouredMesh
from shellvox.printer import build_material_plan, load_profile
from shellvox.stack import build_stack
from shellvox.thickness import LIGHTNESS_RULE, face_thickness

J750 = load_profile("j750")
DEFAULT_MODEL = "data/colour_target/colour_target.obj"


def _box(rgba_of_centroid) -> ColouredMesh:
    box = trimesh.creation.box((8.0, 8.0, 8.0)).subdivide().subdivide().subdivide()
    faces = box.faces.astype(np.int64)
    rgba = rgba_of_centroid(box.triangles_center).astype(np.uint8)
    return ColouredMesh(box.vertices, faces, "face", face_rgba=rgba, source="box")


def _white_and_black(centroid):
    rgba = np.full((len(centroid), 4), 128, np.uint8)
    rgba[:, 3] = 255
    rgba[centroid[:, 0] > 3.99] = (255, 255, 255, 255)  # +x face white
    rgba[centroid[:, 0] < -3.99] = (0, 0, 0, 255)  # -x face black
    return rgba


def _read(path):
    with tifffile.TiffFile(path) as tiff:
        return tiff.asarray()


def test_white_colour_layer_is_deeper_than_black_in_the_voxels(tmp_path):
    # the lightness rule makes white deeper than black; the voxels follow any rule's faces
    mesh = _box(_white_and_black)
    faces = face_thickness(mesh, LIGHTNESS_RULE)
    thickness = faces.thickness_mm
    config = BuildConfig(
        voxel_mm=(0.04, 0.04, 0.04),
        thickness_mm=tuple(float(np.median(t)) for t in thickness),
        thickness_source="default rule",
        shell_meshes=False,
        formats=("tiff",),
        material=None,
    )
    manifest = build_stack(mesh, config, tmp_path, thickness=thickness, faces=faces)
    layers = _read(tmp_path / "layers.tif")
    grid = manifest["grid"]
    origin, voxel = np.array(grid["origin_mm"]), np.array(grid["voxel_size_mm"])
    z, y = (np.rint((0.0 - origin[2]) / voxel[2]), np.rint((0.0 - origin[1]) / voxel[1]))
    row = layers[int(z), int(y)]  # the x row through the centres of the +x and -x faces
    x = origin[0] + voxel[0] * np.arange(len(row))
    colour = row == 1
    white_depth = 4.0 - x[colour & (x > 0)].min()  # from the +x face inward
    black_depth = x[colour & (x < 0)].max() + 4.0
    centre = np.abs(mesh.vertices[mesh.faces].mean(axis=1)[:, 1:]).max(axis=1) < 1.0
    want_white = thickness[0][(mesh.face_rgba[:, 0] == 255) & centre]
    want_black = thickness[0][(mesh.face_rgba[:, 0] == 0) & centre]
    # the voxels hold the rule's per-face depth (within one voxel) ...
    assert white_depth == pytest.approx(float(np.median(want_white)), abs=voxel[0])
    assert black_depth == pytest.approx(float(np.median(want_black)), abs=voxel[0])
    # ... and white's colour layer is measurably deeper than black's
    assert white_depth > black_depth + 0.3, (white_depth, black_depth)
    # the per-face thickness is written as read back by trimesh
    ply = trimesh.load(tmp_path / "thickness.ply", process=False)
    assert len(ply.faces) == len(mesh.faces)
    assert manifest["thickness"]["source"] == "default rule"


def _sphere(alpha_right: int = 255) -> ColouredMesh:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=2.5)
    centroid = sphere.triangles_center
    rgba = np.zeros((len(sphere.faces), 4), np.uint8)
    rgba[:] = (40, 160, 220, 255)
    rgba[centroid[:, 0] > 0] = (230, 120, 40, alpha_right)
    return ColouredMesh(
        sphere.vertices, sphere.faces.astype(np.int64), "face", face_rgba=rgba, source="sphere"
    )


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    out = tmp_path_factory.mktemp("job")
    config = BuildConfig(
        voxel_mm=J750.voxel_mm,
        printer="j750",
        thickness_mm=(0.4, 0.3),
        alpha=True,
        shell_meshes=False,
        formats=("tiff", "gcvf", "png"),
        report_samples=2000,
    )
    manifest = build_stack(_sphere(alpha_right=128), config, out, profile=J750, progress=False)
    return out, manifest


def _gcvf(path):
    with zipfile.ZipFile(path) as archive:
        config = ET.fromstring(archive.read("ConfigFile.xml"))
        names = [n for n in archive.namelist() if n.startswith("layer_")]
        slices = {
            int(re.fullmatch(r"layer_(\d+)\.png", n).group(1)): archive.read(n) for n in names
        }
    return config, slices


def test_gcvf_parses_back_and_agrees_with_materials_tif(job):
    out, manifest = job
    config, slices = _gcvf(out / "job.gcvf")
    materials = _read(out / "materials.tif")
    n_z, n_y, n_x = materials.shape
    count = int(config.findtext("SliceRange/NumberOfSlices"))
    assert sorted(slices) == list(range(count)) and count >= max(30, n_z)
    assert int(config.findtext("SliceDimensions/SliceWidth")) == n_x
    assert int(config.findtext("SliceDimensions/SliceHeight")) == n_y
    keys = {
        tuple(int(v) for v in m.findtext("RGBA").split()): (
            m.findtext("Name"),
            int(m.findtext("VoxelCount")),
        )
        for m in config.iter("Material")
    }
    background_text = config.findtext("MaterialList/BackGroundMaterialRGBA")
    background = tuple(int(v) for v in background_text.split())
    key_of = {m.index: m.rgba_key for m in J750.materials}
    seen: dict[tuple[int, ...], int] = {}
    for n in range(count):
        with Image.open(io.BytesIO(slices[n])) as image:
            assert image.mode in ("RGB", "RGBA") and image.size == (n_x, n_y)
            pixels = np.asarray(image.convert("RGBA")).reshape(-1, 4)
        found, counts = np.unique(pixels, axis=0, return_counts=True)
        for key, c in zip(map(tuple, found), counts, strict=True):
            assert key in keys or key == background, key
            seen[key] = seen.get(key, 0) + int(c)
        if n < n_z:  # voxel for voxel: image row 0 is the largest y
            expected = np.array([key_of[i] for i in range(len(J750.materials))])[materials[n]]
            assert np.array_equal(pixels.reshape(n_y, n_x, 4), expected[::-1])
    for key, (_, voxels) in keys.items():
        assert voxels == seen.get(key, 0)
    assert {m["job_name"] for m in manifest["materials"] if m["index"]} == {
        name for name, _ in keys.values()
    }


def test_the_jobs_box_height_map_and_surface_are_the_builds(job):
    # Read back with zipfile, numpy, Pillow and trimesh; compared with materials.tif
    # (tifffile) and the sphere that was built.
    out, _ = job
    materials = _read(out / "materials.tif")
    n_z, n_y, n_x = materials.shape
    with zipfile.ZipFile(out / "job.gcvf") as archive:
        names = archive.namelist()
        box = np.frombuffer(archive.read("MeshBbx.ktn"), "<f4")
        with Image.open(io.BytesIO(archive.read("Zbuffer.png"))) as image:
            assert image.mode.startswith("I;16")
            zbuffer = np.asarray(image)
        surface = trimesh.load(io.BytesIO(archive.read("Mesh.stl")), file_type="stl")
        n_slices = int(
            ET.fromstring(archive.read("ConfigFile.xml")).findtext("SliceRange/NumberOfSlices")
        )
    assert names[-4:] == ["MeshBbx.ktn", "Zbuffer.png", "Mesh.stl", "ConfigFile.xml"]
    assert box.tolist() == [0, 0, 0, n_x, n_y, n_slices]
    solid = materials != 0
    top = np.where(solid.any(axis=0), n_z - 1 - np.argmax(solid[::-1], axis=0), 0)
    np.testing.assert_array_equal(zbuffer, top[::-1])  # row 0 is the largest y
    # The sphere in mm, its box's corner the corner of voxel (0, 0, 0).
    manifest = json.loads((out / "manifest.json").read_text())
    grid = manifest["grid"]
    corner = np.asarray(grid["origin_mm"]) - 0.5 * np.asarray(grid["voxel_size_mm"])
    sphere = _sphere()
    assert len(surface.faces) == len(sphere.faces) and surface.is_watertight
    np.testing.assert_allclose(
        surface.bounds,
        [sphere.vertices.min(0) - corner, sphere.vertices.max(0) - corner],
        atol=1e-5,
    )
    # The surface sits where the voxels are: its top at the height map's highest slice.
    top_mm = float(surface.bounds[1, 2])
    assert abs(top_mm / grid["voxel_size_mm"][2] - (top.max() + 0.5)) <= 1.0


def test_materials_follow_the_layers(job):
    out, _ = job
    layers, materials = _read(out / "layers.tif"), _read(out / "materials.tif")
    roles = {m.index: m.role for m in J750.materials}
    colour_roles = {"cyan", "magenta", "yellow", "black", "clear"}
    outside, colour, backing, core = (layers == k for k in range(4))
    assert np.all(materials[outside] == 0)
    assert {roles[i] for i in np.unique(materials[colour])} <= colour_roles | {"white"}
    assert np.all(materials[backing] == J750.material("white").index)
    assert np.all(materials[core] == J750.material("white").index)
    assert not np.isin(materials[~colour], [J750.material(r).index for r in colour_roles]).any()


def test_translucent_faces_get_clear_and_the_slices_carry_alpha(job):
    out, _ = job
    layers, materials = _read(out / "layers.tif"), _read(out / "materials.tif")
    rgba = _read(out / "colour.tif")
    colour = layers == 1
    clear = materials == J750.material("clear").index
    translucent = colour & (rgba[..., 3] == 128)
    opaque = colour & (rgba[..., 3] == 255)
    assert translucent.sum() > 5000 and opaque.sum() > 5000
    plan = build_material_plan(J750, MaterialSettings(), colour_layers=(1,), n_bands=2)
    share = plan.separation.proportions(np.array([[230, 120, 40, 128]], np.uint8))[0]
    expected_clear = float(share[plan.separation.roles.index("clear")])
    assert clear[translucent].mean() == pytest.approx(expected_clear, abs=0.05)
    assert clear[opaque].sum() == 0
    # the RGBA slice folder, read back with Pillow, carries the alpha
    z = int(np.argmax(translucent.sum(axis=(1, 2))))
    with Image.open(out / "slices" / f"slice_{z:05d}.png") as image:
        assert image.mode == "RGBA"
        alpha = np.asarray(image)[::-1, :, 3]  # row 0 is the largest y
    assert np.all(alpha[translucent[z]] == 128)
    assert np.all(alpha[opaque[z]] == 255)
    assert np.all(alpha[layers[z] == 0] == 0)


@pytest.mark.slow
def test_default_model_job(tmp_path, capsys):
    """``make demo``'s build: the .gcvf of the default model on the J750 grid."""
    out = tmp_path / "demo"
    assert main(["build", DEFAULT_MODEL, "-o", str(out), "--no-progress"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    config, slices = _gcvf(out / "job.gcvf")
    materials = _read(out / "materials.tif")
    assert len(slices) == int(config.findtext("SliceRange/NumberOfSlices")) >= materials.shape[0]
    totals = {m["job_name"]: m["voxels"] for m in manifest["materials"]}
    for material in config.iter("Material"):
        assert int(material.findtext("VoxelCount")) == totals[material.findtext("Name")]
    index = {m.job_name: m.index for m in J750.materials}
    for name, voxels in totals.items():
        assert int(np.count_nonzero(materials == index[name])) == voxels
    report = manifest["colour_report"]
    assert report["samples_seen"] == report["samples"]
    # the user's line gives the manifest's errors apart
    (line,) = [ln for ln in capsys.readouterr().out.splitlines() if "predicted colour" in ln]
    aim, gamut = report["reproduction_inside_colour_regions"], report["gamut"]
    assert f"({report['in_gamut_samples']:,}) median {report['in_gamut']['median']:.2f}" in line
    assert f"separation's aim inside colour regions median {aim['median']:.2f}" in line
    assert line.endswith(f"gamut error median {gamut['median']:.2f}, p95 {gamut['p95']:.2f}")
    # the optics the report used, as written: every printed material of materials.tif
    optics = json.loads((out / "manifest.json").read_text())["optics"]
    assert optics["assumed"] is True and report["optics"] == "assumed"
    assert {m["index"]: m["name"] for m in optics["materials"]} == {
        m.index: m.name for m in J750.materials[1:]
    }
    assert set(np.unique(materials).tolist()) - {0} <= {m["index"] for m in optics["materials"]}
    for m in optics["materials"]:
        assert len(m["k_per_mm"]) == len(m["s_per_mm"]) == len(optics["wavelengths_nm"])
    assert main(["inspect", str(out)]) == 0
    assert any(p.name.startswith("halftone_z") for p in (out / "preview").iterdir())
