"""``--format zarr``: the OME-Zarr 0.5 store beside the TIFF stacks (issue 26).

Independent truth: the NGFF 0.5 models of ``ome-zarr-models`` (validation), ome-zarr-py's
reader, the TIFF stacks read with tifffile, the manifest's grid and materials, and a
reference pyramid level computed here another way (per-value block counts with
``np.add.reduceat``; colour-science's sRGB curve).
"""

from __future__ import annotations

import json
from pathlib import Path

import colour
import numpy as np
import pytest
import tifffile
import zarr
from build_compare import differences, manifest_core, output_digests
from ome_zarr.io import parse_url
from ome_zarr.reader import Label, Multiscales, Reader
from ome_zarr_models.v05.image import Image
from ome_zarr_models.v05.image_label import ImageLabel

from shellvox.cli import main
from shellvox.output import verify_files
from shellvox.run import RUN_FOLDER, RunFolder

MODEL = Path(__file__).resolve().parents[2] / "data" / "colour_target" / "colour_target.obj"
#: The default model on a coarse grid, in several slabs (the pyramid's rows carried over),
#: as the ``small_zarr_build`` fixture builds it.
SMALL = ["--voxel-size", "0.2,0.2,0.15", "--report-samples", "0", "--slab-mb", "2",
         "--no-progress"]  # fmt: skip


def _build(out: Path, *options: str) -> int:
    return main(["build", str(MODEL), "-o", str(out), *options])


@pytest.fixture
def build(small_zarr_build):
    """The default model with --format tiff,zarr (SMALL): read-only."""
    return small_zarr_build


def _tiff(path: Path) -> np.ndarray:
    return tifffile.imread(path)


def test_the_store_validates_as_ome_zarr_05(build):
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    image = Image.from_zarr(root)
    assert image.labels is not None
    assert sorted(image.labels.label_paths) == ["layers", "materials"]
    for name in ("materials", "layers"):
        label = ImageLabel.from_zarr(root[f"labels/{name}"])
        assert len(label.attributes.ome.multiscales[0].datasets) == len(
            image.attributes.ome.multiscales[0].datasets
        )


def test_level_0_is_the_tiff_stacks(build):
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    assert np.array_equal(root["labels/materials/0"][:], _tiff(build / "materials.tif"))
    assert np.array_equal(root["labels/layers/0"][:], _tiff(build / "layers.tif"))
    colour_tif = _tiff(build / "colour.tif")  # (z, y, x, c)
    assert np.array_equal(np.moveaxis(root["0"][:], 0, -1), colour_tif)


def test_axes_units_scale_and_translation_are_the_grid(build):
    manifest = json.loads((build / "manifest.json").read_text())
    (vx, vy, vz), (ox, oy, oz) = manifest["grid"]["voxel_size_mm"], manifest["grid"]["origin_mm"]
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    factors = manifest["zarr"]["level_factors_zyx"]
    for group, lead in ((root, ["c"]), (root["labels/materials"], []), (root["labels/layers"], [])):
        (multiscale,) = group.attrs["ome"]["multiscales"]
        axes = multiscale["axes"]
        assert [a["name"] for a in axes] == [*lead, "z", "y", "x"]
        space = [a for a in axes if a["name"] != "c"]
        assert all(a["type"] == "space" and a["unit"] == "millimeter" for a in space)
        assert all(a["type"] == "channel" for a in axes if a["name"] == "c")
        total = np.ones(3)
        for level, dataset in enumerate(multiscale["datasets"]):
            if level:
                total *= factors[level - 1]
            scale, translation = (t[t["type"]] for t in dataset["coordinateTransformations"])
            n = len(lead)
            np.testing.assert_allclose(scale[n:], np.array([vz, vy, vx]) * total)
            centre = np.array([oz, oy, ox]) + (total - 1) / 2 * np.array([vz, vy, vx])
            np.testing.assert_allclose(translation[n:], centre)
            shape = root[dataset["path"]].shape[-3:]
            assert shape == tuple(
                int(-(-s // t)) for s, t in zip(root["0"].shape[1:], total, strict=True)
            )
    assert root["0"].shape[0] == 3  # RGB (no alpha asked for)


def test_every_used_material_has_its_colour_and_name(build):
    manifest = json.loads((build / "manifest.json").read_text())
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    label = root["labels/materials"].attrs["ome"]["image-label"]
    colours = {c["label-value"]: c["rgba"] for c in label["colors"]}
    properties = {p["label-value"]: p for p in label["properties"]}
    used = set(np.unique(_tiff(build / "materials.tif")).tolist()) - {0}
    assert used and used <= set(colours)
    for material in manifest["materials"]:
        if material["index"] in used:
            assert colours[material["index"]] == [*material["display_srgb"], 255]
            assert properties[material["index"]]["name"] == material["name"]
            assert properties[material["index"]]["role"] == material["role"]
    layers = root["labels/layers"].attrs["ome"]["image-label"]["properties"]
    assert [p["name"] for p in layers] == [layer["name"] for layer in manifest["layers"]]


def test_ome_zarr_py_reads_the_image_and_its_labels(build):
    nodes = list(Reader(parse_url(str(build / "stack.ome.zarr")))())
    image = nodes[0]
    assert any(isinstance(spec, Multiscales) for spec in image.specs)
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    assert [tuple(level.shape) for level in image.data] == [
        root[str(k)].shape for k in range(len(image.data))
    ]
    assert np.array_equal(np.asarray(image.data[0]), root["0"][:])
    labelled = {
        n.metadata.get("name"): n for n in nodes if any(isinstance(s, Label) for s in n.specs)
    }
    assert set(labelled) == {"materials", "layers"}
    assert np.array_equal(np.asarray(labelled["materials"].data[0]), _tiff(build / "materials.tif"))


def _block_sums(values: np.ndarray, factors) -> np.ndarray:
    """Sum of every block (partial ones at the far edges) along the last three axes."""
    for axis, f in zip((-3, -2, -1), factors, strict=True):
        values = np.add.reduceat(values, np.arange(0, values.shape[axis], f), axis=axis)
    return values


def _mode_reference(labels: np.ndarray, factors) -> np.ndarray:
    values = np.unique(labels)  # ascending: argmax picks the smallest of tied values
    counts = np.stack([_block_sums((labels == v).astype(np.int64), factors) for v in values])
    return values[np.argmax(counts, axis=0)].astype(np.uint8)


def _mean_reference(rgb: np.ndarray, coloured: np.ndarray, factors) -> np.ndarray:
    linear = colour.cctf_decoding(rgb / 255.0, function="sRGB") * coloured[None]
    n = _block_sums(coloured.astype(np.float64), factors)
    sums = _block_sums(linear, factors)
    mean = np.divide(sums, n, out=np.zeros_like(sums), where=n > 0)
    encoded = np.rint(colour.cctf_encoding(mean, function="sRGB") * 255.0)
    return np.where(n > 0, encoded, 0).astype(np.uint8)


def test_level_1_is_the_mode_of_labels_and_the_linear_mean_of_colour(build):
    manifest = json.loads((build / "manifest.json").read_text())
    factors = manifest["zarr"]["level_factors_zyx"][0]
    root = zarr.open_group(build / "stack.ome.zarr", mode="r")
    layers = _tiff(build / "layers.tif")
    for name, level0 in (("materials", _tiff(build / "materials.tif")), ("layers", layers)):
        assert np.array_equal(root[f"labels/{name}/1"][:], _mode_reference(level0, factors))
    colour_layers = [layer["index"] for layer in manifest["layers"] if layer["colour"]]
    coloured = np.isin(layers, colour_layers)
    rgb = np.moveaxis(_tiff(build / "colour.tif"), -1, 0)
    expected = _mean_reference(rgb, coloured, factors)
    got = root["1"][:]
    assert got.shape == expected.shape and np.count_nonzero(expected) > 1000
    assert np.abs(got.astype(int) - expected).max() <= 1  # float32 sums against float64
    assert np.mean(got != expected) < 1e-3


def _stored_inner_chunks(shard: bytes, n_chunks: int) -> np.ndarray:
    """Which inner chunks a shard stores: its index (at the end, before a CRC32C) holds an
    (offset, nbytes) uint64 pair per chunk, both 2**64 - 1 for a chunk not stored."""
    index = np.frombuffer(shard[-(16 * n_chunks + 4) : -4], dtype="<u8").reshape(-1, 2)
    return ~np.all(index == np.iinfo(np.uint64).max, axis=1)


def test_void_chunks_are_not_stored_and_inspect_verifies_every_file(build, capsys):
    manifest = json.loads((build / "manifest.json").read_text())
    store = build / "stack.ome.zarr"
    on_disk = sorted(str(p.relative_to(build)) for p in store.rglob("*") if p.is_file())
    assert on_disk == sorted(n for n in manifest["files"] if n.startswith("stack.ome.zarr/"))
    array_meta = json.loads((store / "labels/layers/0/zarr.json").read_text())
    shard_zyx = array_meta["chunk_grid"]["configuration"]["chunk_shape"]
    (codec,) = array_meta["codecs"]
    assert codec["name"] == "sharding_indexed"
    inner = codec["configuration"]["chunk_shape"]
    layers = _tiff(build / "layers.tif")
    grid = [-(-n // s) for n, s in zip(layers.shape, shard_zyx, strict=True)]
    padded = np.zeros([g * s for g, s in zip(grid, shard_zyx, strict=True)], np.uint8)
    padded[: layers.shape[0], : layers.shape[1], : layers.shape[2]] = layers
    n_files, stored = 0, []
    for i in range(grid[0]):
        for j in range(grid[1]):
            for k in range(grid[2]):
                block = padded[
                    i * shard_zyx[0] : (i + 1) * shard_zyx[0],
                    j * shard_zyx[1] : (j + 1) * shard_zyx[1],
                    k * shard_zyx[2] : (k + 1) * shard_zyx[2],
                ]
                counts = [s // c for s, c in zip(shard_zyx, inner, strict=True)]
                solid = block.reshape(counts[0], inner[0], counts[1], inner[1], counts[2], inner[2])
                solid = solid.any(axis=(1, 3, 5)).reshape(-1)
                path = store / f"labels/layers/0/c/{i}/{j}/{k}"
                if not solid.any():
                    assert not path.exists()
                    continue
                n_files += 1
                assert np.array_equal(_stored_inner_chunks(path.read_bytes(), solid.size), solid)
                stored.append(solid)
    assert n_files >= 1 and np.concatenate(stored).any()
    assert main(["inspect", "--no-preview", str(build)]) == 0
    assert "stack.ome.zarr/" in capsys.readouterr().out
    verify_files(build, manifest)


def test_same_inputs_same_bytes_wherever_encoded_and_resumed(tmp_path, monkeypatch):
    options = [*SMALL, "--format", "zarr", "--workers", "2", "--checkpoint"]
    reference, out = tmp_path / "reference", tmp_path / "out"
    assert _build(reference, *options) == 0
    with monkeypatch.context() as patch:  # as if killed once the manifest was written
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(out, *options) == 0
    assert output_digests(out) == output_digests(reference)
    here = tmp_path / "here"  # level 0 encoded by the writer, not by the slab workers
    assert _build(here, *SMALL, "--format", "zarr", "--workers", "1") == 0
    assert output_digests(here) == output_digests(reference)
    chunks = sorted((out / RUN_FOLDER).glob("slab_*.npz"))
    assert len(chunks) >= 3
    for chunk in chunks[1::2]:
        chunk.unlink()
    assert _build(out, *options, "--resume") == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["run"]["resumed_slabs"] == len(chunks) - len(chunks[1::2])
    assert output_digests(out) == output_digests(reference)
    assert differences(manifest_core(out), manifest_core(reference)) == []
    assert not any(n.endswith(".tif") for n in manifest["files"])


def test_store_is_the_same_whether_slab_workers_or_the_writer_encode_level_0(tmp_path):
    fine = ["--voxel-size", "0.2,0.2,0.05", "--report-samples", "0", "--no-progress"]
    options = [*fine, "--format", "zarr", "--workers", "2"]
    whole, thin = tmp_path / "whole", tmp_path / "thin"
    assert _build(whole, *options, "--slab-mb", "32.5") == 0  # 64-row slabs: whole shards
    assert _build(thin, *options, "--slab-mb", "2") == 0  # 3-row slabs: the writer's shards
    manifests = [json.loads((out / "manifest.json").read_text()) for out in (whole, thin)]
    assert [m["slab_rows"] for m in manifests] == [64, 3]
    assert manifests[0]["grid"]["shape_zyx"][0] > 64  # level 0 has several shards
    store = {name: digest for name, digest in output_digests(whole).items() if "zarr" in name}
    assert len([name for name in store if "/0/c/" in name]) >= 2
    assert store == {n: d for n, d in output_digests(thin).items() if "zarr" in n}
    # resumed with one slab left, computed here without its shards, the others' loaded
    resumed = tmp_path / "resumed"
    checkpointed = [*options, "--slab-mb", "32.5", "--checkpoint"]
    with pytest.MonkeyPatch.context() as patch:  # as if killed once the manifest was written
        patch.setattr(RunFolder, "remove", lambda self: None)
        assert _build(resumed, *checkpointed) == 0
    chunks = sorted((resumed / RUN_FOLDER).glob("slab_*.npz"))
    assert len(chunks) >= 3
    chunks[1].unlink()
    assert _build(resumed, *checkpointed, "--resume") == 0
    manifest = json.loads((resumed / "manifest.json").read_text())
    assert manifest["run"]["resumed_slabs"] == len(chunks) - 1
    assert store == {n: d for n, d in output_digests(resumed).items() if "zarr" in n}
