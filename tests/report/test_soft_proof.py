"""The soft proof shows what the two-flux model says of the voxels as written.

A 10 mm box, each side one colour, is built for the J750 at 0.05 mm voxels and
inspected. The checks are independent of shellvox's own model code:

- the material voxels are read from ``materials.tif`` with tifffile: under the middle of
  a side, each voxel layer's material shares (Duncan's mix of the profile's K and S) and
  its thickness inside the part; Kubelka's hyperbolic solution for each layer, the layers
  stacked over the deepest mix (infinitely deep) with the textbook composition rule,
  Saunderson's surface correction, and colour-science's ``sd_to_XYZ`` (D50, CIE 1931 2
  degree) give the colour those voxels print; the proof's prediction there must agree;
- ``proof.ply`` is read by trimesh; ``soft_proof.png`` by Pillow (its panel boxes from
  its PNG text chunk): the side whose colour is outside the gamut is hatched in the
  error panel, the in-gamut side is not, and shows its reproduction error.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace

import colour
import numpy as np
import pytest
import tifffile
import trimesh
from PIL import Image

import shellvox
from shellvox.report._previews import _proof_legend
from shellvox.voxel.colour import IN_GAMUT_DE
from shellvox.voxel.io import HATCH_RGB, de_colours

VOXEL_MM = 0.05
HALF = 5.005  # half side, mm: the + faces lie between voxel centres, the - faces on them
SIDES = {  # outward normal: sRGB
    (1, 0, 0): (0, 255, 0),  # sRGB green: far outside a CMYK-and-white gamut
    (-1, 0, 0): (200, 170, 150),  # a pastel inside it
    (0, 1, 0): (90, 120, 170),
    (0, -1, 0): (230, 230, 230),
    (0, 0, 1): (150, 60, 90),
    (0, 0, -1): (128, 128, 128),
}
#: Half the side of the square under a side's middle whose voxels are read, mm.
PATCH_MM = 1.5
#: How deep the columns are read, mm (the colour report's depth).
DEPTH_MM = 2.0


#: A dark 1 mm square on every side, centred MARKER_MM along both of the side's other axes.
MARKER_RGB = (25, 25, 25)
MARKER_MM = 3.0


@pytest.fixture(scope="module")
def box_build(tmp_path_factory):
    folder = tmp_path_factory.mktemp("soft_proof")
    box = trimesh.creation.box(extents=(2 * HALF,) * 3).subdivide_to_size(0.25)
    rgba = np.full((len(box.faces), 4), 255, np.uint8)
    for normal, srgb in SIDES.items():
        rgba[np.all(np.isclose(box.face_normals, normal), axis=1), :3] = srgb
    across = np.abs(box.face_normals) < 0.5  # each face's two in-plane axes
    centres = box.triangles_center
    marker = np.all(np.where(across, np.abs(centres - MARKER_MM) <= 0.5, True), axis=1)
    rgba[marker, :3] = MARKER_RGB
    box.visual.face_colors = rgba
    box.export(folder / "box.ply")
    options = shellvox.BuildOptions(
        printer="j750", voxel_size_mm=(VOXEL_MM,) * 3, formats=("tiff",)
    )
    result = shellvox.build(folder / "box.ply", folder / "out", options)
    inspection = shellvox.inspect_build(result.folder)
    return result.folder, inspection


def _middle(points, normals, normal):
    """Samples on the side with `normal` within the read square around its middle."""
    on_side = np.all(np.abs(normals - normal) < 1e-3, axis=1)
    across = np.abs(points) * (1 - np.abs(np.asarray(normal)))
    return on_side & (across.max(axis=1) <= PATCH_MM)


def _kubelka(k, s, t):
    """Reflectance and transmittance of a layer (Kubelka 1948, hyperbolic form)."""
    a = (s + k) / s
    b = np.sqrt(a * a - 1.0)
    bst = b * s * t
    denominator = a * np.sinh(bst) + b * np.cosh(bst)
    return np.sinh(bst) / denominator, b / denominator


def _printed_lab(folder, manifest, normal):
    """CIELAB the two-flux model gives the voxels under the side's middle (see module)."""
    materials = tifffile.imread(folder / "materials.tif")  # (z, y, x)
    grid = manifest["grid"]
    origin = np.asarray(grid["origin_mm"])
    voxel = np.asarray(grid["voxel_size_mm"])
    axis = int(np.flatnonzero(normal)[0])  # x, y or z
    sign = int(normal[axis])
    centres = [origin[i] + voxel[i] * np.arange(n) for i, n in enumerate(grid["shape_zyx"][::-1])]
    # depth of each voxel slab's faces below the side, and the part within [0, DEPTH_MM]
    along, half_voxel = centres[axis], voxel[axis] / 2
    first, second = HALF - sign * (along - half_voxel), HALF - sign * (along + half_voxel)
    top, bottom = np.minimum(first, second), np.maximum(first, second)
    thickness = np.clip(bottom, 0, DEPTH_MM) - np.clip(top, 0, DEPTH_MM)
    layers = np.flatnonzero(thickness > 1e-9)
    layers = layers[np.argsort(top[layers])]  # from the surface in
    in_patch = [np.abs(c) <= PATCH_MM for c in centres]
    index = [np.flatnonzero(m) for m in in_patch]
    index[axis] = layers
    block = materials[np.ix_(index[2], index[1], index[0])]  # (z, y, x) of the square
    block = np.moveaxis(block, 2 - axis, 0).reshape(len(layers), -1)  # (layer, voxels)
    profile = shellvox.load_profile("j750")
    optics = profile.optics
    n_materials = len(optics.names)
    counts = np.stack([(block == m + 1).sum(axis=1) for m in range(n_materials)], axis=1)
    # a voxel layer's mix is that of its material voxels (the layer of centres on the
    # surface is partly void); its thickness is the part of it inside the box
    filled = counts.sum(axis=1) > 0
    assert filled[1:].all() and counts[1:].sum(axis=1).min() == block.shape[1]
    counts, layers = counts[filled], layers[filled]
    shares = counts / counts.sum(axis=1, keepdims=True)
    k, s = shares @ optics.k_per_mm, shares @ optics.s_per_mm  # (layer, band)
    a = (s[-1] + k[-1]) / s[-1]
    reflectance = a - np.sqrt(a * a - 1.0)  # the deepest mix, infinitely deep
    for i in range(len(layers) - 1, -1, -1):
        r, t = _kubelka(k[i], s[i], thickness[layers[i]])
        reflectance = r + t * t * reflectance / (1.0 - r * reflectance)
    k1, k2 = optics.k1, optics.k2
    measured = k1 + (1 - k1) * (1 - k2) * reflectance / (1 - k2 * reflectance)
    shape = colour.SpectralShape(optics.wavelengths_nm[0], optics.wavelengths_nm[-1], 10)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    illuminant = colour.SDS_ILLUMINANTS["D50"].copy().align(shape)

    def xyz(values):
        sd = colour.SpectralDistribution(dict(zip(optics.wavelengths_nm, values, strict=True)))
        return colour.sd_to_XYZ(sd, cmfs, illuminant, method="Integration", shape=shape) / 100.0

    white = xyz(np.ones(len(optics.wavelengths_nm)))
    return colour.XYZ_to_Lab(xyz(measured), colour.XYZ_to_xy(white))


@pytest.mark.parametrize("normal", list(SIDES))
def test_prediction_is_the_two_flux_colour_of_the_voxels_as_written(box_build, normal):
    folder, inspection = box_build
    manifest = inspection.manifest
    cloud = trimesh.load(folder / "proof.ply")
    rows = cloud.metadata["_ply_raw"]["vertex"]["data"]
    normals = np.stack([rows["nx"], rows["ny"], rows["nz"]], axis=1)
    chosen = _middle(np.asarray(cloud.vertices), normals, normal)
    assert chosen.sum() >= 100
    predicted = np.stack([rows[f"predicted_{c}"][chosen] for c in "Lab"], axis=1).mean(axis=0)
    expected = _printed_lab(folder, manifest, normal)
    error = float(colour.delta_E(predicted, expected, method="CIE 2000"))
    assert error <= 1.0, (normal, predicted.round(2), expected.round(2), error)


def _panel(image, boxes, view, panel):
    left, top, width, height = boxes[view][panel]
    return np.asarray(image.convert("RGB"))[top : top + height, left : left + width]


def test_out_of_gamut_side_shows_gamut_error_in_gamut_side_its_reproduction(box_build):
    folder, inspection = box_build
    proof = shellvox.open_build(folder).soft_proof()
    outside = _middle(proof.points_mm, proof.normals, (1, 0, 0))  # sRGB green
    inside = _middle(proof.points_mm, proof.normals, (-1, 0, 0))  # the pastel
    assert np.median(proof.gamut_de[outside]) > 5.0
    assert np.median(proof.gamut_de[inside]) <= 1.0
    # in gamut, the error is the reproduction's; outside, the gamut's dominates
    assert np.allclose(proof.total_de[inside], proof.reproduction_de[inside], atol=1.0)
    assert np.median(proof.total_de[outside]) > 3 * np.median(proof.reproduction_de[outside])
    picture = next(p for p in inspection.previews if p.name == "soft_proof.png")
    with Image.open(picture) as image:
        boxes = json.loads(image.text["shellvox:panels"])
        from_plus_x = _panel(image, boxes, "right (from +x; y right, z up)", "total_de")
        from_minus_x = _panel(image, boxes, "left (from -x; y left, z up)", "total_de")
    hatched = np.all(from_plus_x == HATCH_RGB, axis=-1)
    drawn = np.any(from_plus_x != 255, axis=-1)
    assert hatched.sum() > 0.1 * drawn.sum()  # lines one pixel in six
    height, width = from_minus_x.shape[:2]  # the side's middle (its corner has the marker)
    middle = from_minus_x[height // 3 : 2 * height // 3, width // 3 : 2 * width // 3]
    assert not np.all(middle == HATCH_RGB, axis=-1).any()


#: Each view: the side it sees, and its panels' axes as its label states them (the axis
#: that runs along the columns, whether it grows to the right; the axis that grows up).
VIEWS = {
    "top (from +z; x right, y up)": ((0, 0, 1), (0, True), 1),
    "front (from -y; x right, z up)": ((0, -1, 0), (0, True), 2),
    "right (from +x; y right, z up)": ((1, 0, 0), (1, True), 2),
    "bottom (from -z; x left, y up)": ((0, 0, -1), (0, False), 1),
    "back (from +y; x left, z up)": ((0, 1, 0), (0, False), 2),
    "left (from -x; y left, z up)": ((-1, 0, 0), (1, False), 2),
}


def _pixel(manifest, box, point, columns, up):
    """Row and column of a panel where the grid point ``(x, y, z)`` is drawn (its label)."""
    grid = manifest["grid"]
    counts = grid["shape_zyx"][::-1]

    def fraction(axis):  # where the point lies across the grid's voxels, 0..1
        origin, size = grid["origin_mm"][axis], grid["voxel_size_mm"][axis]
        return ((point[axis] - origin) / size + 0.5) / counts[axis]

    left, top, width, height = box
    axis, grows_right = columns
    column = int(fraction(axis) * width)
    row = height - 1 - int(fraction(up) * height)
    return top + row, left + (column if grows_right else width - 1 - column)


def test_every_view_shows_its_side_where_its_label_says_with_its_1_mm_patch(box_build):
    folder, inspection = box_build
    manifest = inspection.manifest
    build = shellvox.open_build(folder)
    picture = next(p for p in inspection.previews if p.name == "soft_proof.png")
    with Image.open(picture) as image:
        boxes = json.loads(image.text["shellvox:panels"])
        pixels = np.asarray(image.convert("RGB")).astype(int)
    assert set(boxes) == set(VIEWS)
    for view, (normal, columns, up) in VIEWS.items():
        side = int(np.flatnonzero(normal)[0])
        marker = np.full(3, MARKER_MM)
        marker[side] = normal[side] * HALF
        mirrored = marker.copy()
        mirrored[columns[0]] = -MARKER_MM  # the same place mirrored across the columns
        target_box, predicted_box = boxes[view]["target"], boxes[view]["predicted"]
        at_marker = pixels[_pixel(manifest, target_box, marker, columns, up)]
        at_mirror = pixels[_pixel(manifest, target_box, mirrored, columns, up)]
        assert tuple(at_marker) == MARKER_RGB, view
        assert tuple(at_mirror) == SIDES[normal], view
        # the predicted print shows the dark 1 mm patch, as the stored proof has it there
        shown = pixels[_pixel(manifest, predicted_box, marker, columns, up)]
        beside = pixels[_pixel(manifest, predicted_box, mirrored, columns, up)]
        expected = build.soft_proof([marker], normal).srgb("predicted")[0]
        assert shown.mean() < beside.mean() - 25, (view, shown, beside)
        assert np.abs(shown - expected).max() <= 12, (view, shown, expected)


def test_the_error_panels_show_the_stored_errors(box_build):
    folder, inspection = box_build
    build = shellvox.open_build(folder)
    picture = next(p for p in inspection.previews if p.name == "soft_proof.png")
    with Image.open(picture) as image:
        boxes = json.loads(image.text["shellvox:panels"])
        pixels = np.asarray(image.convert("RGB"))
    for view, (normal, columns, up) in VIEWS.items():
        side = int(np.flatnonzero(normal)[0])
        grid = np.linspace(-1.0, 1.0, 5)  # points around the side's middle, mm
        points = np.zeros((25, 3))
        others = [axis for axis in range(3) if axis != side]
        points[:, others[0]], points[:, others[1]] = np.repeat(grid, 5), np.tile(grid, 5)
        points[:, side] = normal[side] * HALF
        stored = build.soft_proof(points, normal)
        errors = {"total_de": stored.total_de, "reproduction_de": stored.reproduction_de}
        for panel, values in errors.items():
            expected = de_colours(values)
            box = boxes[view][panel]
            drawn = np.array(
                [pixels[_pixel(inspection.manifest, box, p, columns, up)] for p in points]
            )
            if panel == "total_de":  # hatched pixels where the target is out of gamut
                lines = np.all(drawn == HATCH_RGB, axis=1)
                assert not lines.any() or (stored.gamut_de > IN_GAMUT_DE).all(), view
                drawn, expected = drawn[~lines], expected[~lines]
            same = np.all(drawn == expected, axis=1)
            assert same.mean() >= 0.8, (view, panel, drawn, expected)


def test_a_build_without_materials_has_no_proof(tmp_path):
    box = trimesh.creation.box(extents=(4.0, 4.0, 4.0))
    box.export(tmp_path / "box.stl")
    options = shellvox.BuildOptions(voxel_size_mm=(0.2,) * 3, formats=("zarr",), materials=None)
    build = shellvox.build(tmp_path / "box.stl", tmp_path / "out", options).open()
    assert "proof" not in build.manifest
    with pytest.raises(shellvox.InputError, match="no soft proof"):
        build.soft_proof()


def test_bad_points_or_a_damaged_proof_are_refused_in_one_line(box_build, tmp_path):
    folder, _ = box_build
    build = shellvox.open_build(folder)
    centre = [[0.0, 0.0, HALF]]
    for points, normals, said in (
        ([[0.0, 0.0]], [0.0, 0.0, 1.0], "points_mm: has shape"),
        ([[np.nan, 0.0, HALF]], [0.0, 0.0, 1.0], "points_mm: holds NaN"),
        (centre, None, "normals: is missing"),
        (centre, [[0.0, 0.0, 1.0]] * 2, "normals: holds 2 rows for 1 points"),
        (centre, [0.0, 0.0, 0.0], "normals: holds a zero vector"),
    ):
        with pytest.raises(shellvox.InputError, match=said) as caught:
            build.soft_proof(points, normals)
        assert "\n" not in str(caught.value)
    damaged = tmp_path / "build"
    shutil.copytree(folder, damaged)
    text = (damaged / "proof.ply").read_bytes().replace(b"comment white_xy", b"comment other")
    (damaged / "proof.ply").write_bytes(text)
    with pytest.raises(shellvox.InputError, match=r"proof\.ply: cannot be read .*white_xy"):
        shellvox.open_build(damaged).soft_proof()


def test_the_legend_names_measured_optics_and_the_drawing_scale(box_build):
    folder, inspection = box_build
    proof = shellvox.open_build(folder).soft_proof()
    assumed = _proof_legend(inspection.manifest, proof, 5.0)
    measured = _proof_legend(inspection.manifest, replace(proof, optics="measured"), 5.0)
    assert "ASSUMED optics" in assumed[0] and "shellvox calibrate" in assumed[0]
    assert "measured optics of printer profile j750" in measured[0]
    assert "ASSUMED" not in " ".join(measured)
    assert "5.0 pixels per mm" in assumed[1]
