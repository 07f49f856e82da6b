from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import tifffile
import trimesh
from skimage import measure

from shellvox.config import BuildConfig
from shellvox.errors import SlabWorkerDied
from shellvox.model import ColouredMesh
from shellvox.offset import method_shells
from shellvox.stack import build_stack
from shellvox.testing import describe_grids, read_vdb


def _ball(radius: float = 3.0) -> ColouredMesh:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=radius)
    faces = sphere.faces.astype(np.int64)
    centroid = sphere.triangles_center
    rgba = np.zeros((len(faces), 4), np.uint8)
    rgba[:, 3] = 255
    rgba[centroid[:, 0] > 0, 0] = 250  # red half, black half (black must stay active)
    return ColouredMesh(sphere.vertices, faces, "face", face_rgba=rgba, source="ball")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("build")
    config = BuildConfig(
        voxel_mm=(0.1, 0.15, 0.08), thickness_mm=(0.4, 0.6), slab_mb=2.0, shell_meshes=True
    )
    manifest = build_stack(_ball(), config, out, progress=False)
    return out, config, manifest


def test_outputs_and_manifest(built):
    out, _, manifest = built
    names = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert names == {
        "manifest.json",
        "layers.tif",
        "colour.tif",
        "volume.vdb",
        "shells/shell_1.ply",
        "shells/shell_2.ply",
    }
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk == manifest  # returned exactly as written, files and total time included
    assert set(on_disk["files"]) == names - {"manifest.json"}
    assert on_disk["seconds"]["total"] > 0
    assert [layer["index"] for layer in on_disk["layers"]] == [0, 1, 2, 3]
    assert on_disk["diagnostics"]["unbalanced_rows"] == 0
    assert manifest["slab_rows"] < manifest["grid"]["shape_zyx"][0]  # really streamed


def test_tiff_round_trip_matches_manifest(built):
    out, _, manifest = built
    grid = manifest["grid"]
    with tifffile.TiffFile(out / "layers.tif") as tiff:
        layers = tiff.asarray()
        assert tiff.imagej_metadata["spacing"] == pytest.approx(grid["voxel_size_mm"][2])
        assert tiff.imagej_metadata["unit"] == "mm"
    colour = tifffile.imread(out / "colour.tif")
    assert list(layers.shape) == grid["shape_zyx"]
    assert colour.shape == (*layers.shape, 3)
    counts = np.bincount(layers.ravel(), minlength=4)
    assert [layer["voxels"] for layer in manifest["layers"]] == counts.tolist()
    assert np.all(colour[layers != 1] == 0)
    reds = set(map(tuple, colour[layers == 1].reshape(-1, 3)))
    assert reds <= {(250, 0, 0), (0, 0, 0)}  # never averaged


def test_layers_are_nested_connected_shells(built):
    # A ball's layers are the outside (one component, no cavity), the colour shell, the
    # backing shell and the core, each one connected piece, and the backing everywhere
    # separates the colour layer from the core (no face shared): labelled by
    # scikit-image's connected components, an implementation independent of the build.
    out, _, _ = built
    layers = tifffile.imread(out / "layers.tif")
    for index in range(4):
        _, n_parts = measure.label(layers == index, connectivity=3, return_num=True)
        assert n_parts == 1, index
    colour, core = layers == 1, layers == 3
    for axis in range(3):
        assert not (colour[_cut(axis, 1)] & core[_cut(axis, -1)]).any()
        assert not (colour[_cut(axis, -1)] & core[_cut(axis, 1)]).any()


def _cut(axis: int, side: int) -> tuple[slice, ...]:
    """The slice dropping the first (side 1) or last (side -1) plane along `axis`."""
    cut = [slice(None)] * 3
    cut[axis] = slice(1, None) if side == 1 else slice(None, -1)
    return tuple(cut)


def test_layers_follow_depth(built):
    out, _, manifest = built
    layers = tifffile.imread(out / "layers.tif")
    g = manifest["grid"]
    z, y, x = np.indices(layers.shape)
    centre = np.stack([x, y, z], axis=-1) * g["voxel_size_mm"] + g["origin_mm"]
    depth = 3.0 - np.linalg.norm(centre, axis=-1)
    expected = (depth > 0).astype(int) + (depth > 0.4) + (depth > 1.0)
    clear = np.min(np.abs(depth[..., None] - np.array([0.0, 0.4, 1.0])), axis=-1) > 0.08
    agree = (layers == expected)[clear].mean()
    assert agree > 0.999


def test_vdb_matches_manifest(built):
    out, _, manifest = built
    summary = describe_grids(read_vdb(out / "volume.vdb"))
    assert summary == manifest["vdb"]
    inside = sum(layer["voxels"] for layer in manifest["layers"][1:])
    assert summary["density"]["active_voxels"] == inside
    assert summary["color"]["active_voxels"] == manifest["layers"][1]["voxels"]
    assert summary["sdf"]["class"] == "level set"
    for grid in summary.values():
        assert grid["voxel_size_mm"] == pytest.approx(manifest["grid"]["voxel_size_mm"])


@pytest.mark.parametrize("workers", [1, 2])
def test_failed_build_leaves_nothing_complete(tmp_path, monkeypatch, workers):
    import shellvox.run._task as slab_task

    def boom(*args, **kwargs):
        raise RuntimeError("slab failed")

    monkeypatch.setattr(slab_task, "compute_slab", boom)  # forked workers inherit it
    config = BuildConfig(
        voxel_mm=(0.2, 0.2, 0.2), thickness_mm=(0.5,), slab_mb=0.5, workers=workers
    )
    with pytest.raises(RuntimeError, match="slab failed"):
        build_stack(_ball(), config, tmp_path, progress=False)
    left = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert left == []


def test_a_dead_worker_fails_the_build_instead_of_hanging(tmp_path, monkeypatch):
    import os

    import shellvox.run._task as slab_task

    def die(*args, **kwargs):
        os._exit(9)  # as when the kernel kills a worker for lack of memory

    monkeypatch.setattr(slab_task, "compute_slab", die)  # only forked workers call it
    config = BuildConfig(voxel_mm=(0.2, 0.2, 0.2), thickness_mm=(0.5,), slab_mb=0.5, workers=2)
    with pytest.raises(SlabWorkerDied, match=r"smaller BuildOptions\(slab_mb=") as died:
        build_stack(_ball(), config, tmp_path, progress=False)
    assert "smaller --slab-mb" in died.value.words("cli")
    assert [p for p in tmp_path.rglob("*") if p.is_file()] == []


def test_worker_processes_give_the_same_stack(tmp_path):
    """Slabs are a pure function: computed in 3 forked workers or here, same bytes."""
    outputs = {}
    for workers in (1, 3):
        config = BuildConfig(
            voxel_mm=(0.1, 0.15, 0.08),
            thickness_mm=(0.4, 0.6),
            slab_mb=1.0,
            shell_meshes=False,
            workers=workers,
        )
        out = tmp_path / str(workers)
        manifest = build_stack(_ball(), config, out, progress=False)
        assert manifest["slab_rows"] * 4 < manifest["grid"]["shape_zyx"][0]  # many slabs
        outputs[workers] = (
            tifffile.imread(out / "layers.tif"),
            tifffile.imread(out / "colour.tif"),
            manifest["voxel_counts"],
            manifest["vdb"],
        )
    serial, parallel = outputs[1], outputs[3]
    np.testing.assert_array_equal(serial[0], parallel[0])
    np.testing.assert_array_equal(serial[1], parallel[1])
    assert serial[2:] == parallel[2:]


def test_vdb_encoded_in_workers_equals_vdb_encoded_here(tmp_path):
    """Slabs of whole leaf rows are VDB-encoded in the workers: the grids OpenVDB reads
    back are those of a build whose slabs the parent regroups and encodes."""
    grids = {}
    for workers, slab_mb in ((3, 2.0), (1, 0.7)):
        config = BuildConfig(
            voxel_mm=(0.1, 0.15, 0.08),
            thickness_mm=(0.4, 0.6),
            slab_mb=slab_mb,
            shell_meshes=False,
            workers=workers,
        )
        out = tmp_path / str(workers)
        manifest = build_stack(_ball(), config, out, progress=False)
        rows = manifest["slab_rows"]
        assert (rows % 8 == 0) == (workers == 3) and rows < manifest["grid"]["shape_zyx"][0]
        shape = tuple(manifest["grid"]["shape_zyx"][::-1])
        grids[workers] = read_vdb(out / "volume.vdb", dense_xyz=shape)
    for name, grid in grids[1].items():
        other = grids[3][name]
        assert grid.active_voxels == other.active_voxels
        np.testing.assert_array_equal(grid.values, other.values)


def test_shell_meshes_come_from_the_voxels_scan(built, tmp_path):
    # The field shells are meshed from the layer field the slabs scanned (one scan), and
    # keeping it changes no voxel: a build without shell meshes has the same files.
    out, config, manifest = built
    record = manifest["shell_meshes"]
    assert record["method"] == "field" and record["field_source"] == "voxels"
    assert record["layer_field_scans"] == 1
    voxel = np.array(manifest["grid"]["voxel_size_mm"])
    stride = np.array(record["node_step_mm"]) / voxel
    np.testing.assert_allclose(stride, np.round(stride))  # nodes are voxel centres
    plain = dataclasses.replace(config, shell_meshes=False)
    other = build_stack(_ball(), plain, tmp_path, progress=False)
    assert "shell_meshes" not in other
    for name in ("layers.tif", "colour.tif", "volume.vdb"):
        assert other["files"][name] == manifest["files"][name], name
    for k in (1, 2):
        shell = trimesh.load(out / "shells" / f"shell_{k}.ply", process=False)
        assert shell.is_watertight and shell.is_winding_consistent and shell.volume > 0


def test_distance_layers_agree_with_the_shells(built):
    _, config, manifest = built
    assert config.layer_rule == "distance"
    agreement = manifest["shell_agreement"]
    # both realise the same bands of the same ball: they may differ only near boundaries
    assert agreement["samples"] > 5000
    # bands 0.4 and 0.6 mm thick, clear = farther than the 0.2 mm voxel diagonal from a
    # limit: about half the samples
    assert agreement["samples_clear"] > 0.3 * agreement["samples"]
    assert agreement["agreement_clear"] >= 0.999
    assert set(agreement["per_layer"]) == {"1", "2", "3"}


@pytest.mark.parametrize(
    ("rule", "meshes", "expect_shells"),
    [("shells", True, True), ("shells", False, False), ("distance", False, False)],
)
def test_layer_rules_and_shell_meshes(tmp_path, rule, meshes, expect_shells):
    config = BuildConfig(
        voxel_mm=(0.2, 0.25, 0.15), thickness_mm=(0.5,), layer_rule=rule, shell_meshes=meshes
    )
    manifest = build_stack(_ball(), config, tmp_path, progress=False)
    assert (tmp_path / "shells" / "shell_1.ply").is_file() == expect_shells
    assert manifest["shell_agreement"] is None
    layers = tifffile.imread(tmp_path / "layers.tif")
    g = manifest["grid"]
    z, y, x = np.indices(layers.shape)
    centre = np.stack([x, y, z], axis=-1) * g["voxel_size_mm"] + g["origin_mm"]
    depth = 3.0 - np.linalg.norm(centre, axis=-1)
    expected = (depth > 0).astype(int) + (depth > 0.5)
    clear = np.min(np.abs(depth[..., None] - np.array([0.0, 0.5])), axis=-1) > 0.08
    assert (layers == expected)[clear].mean() > 0.999
    if rule == "shells" and not meshes:  # the manifest counts the shells the voxels used
        ball = _ball()
        made = method_shells(ball.vertices, ball.faces, [0.5], method=config.shell_method)
        assert manifest["layers"][1]["shell_faces"] == len(made.shells[0].faces)
