"""Open a finished build as arrays: layers, colour and materials, with the grid that places them.

The voxels are read lazily, chunk by chunk, from the build's OME-Zarr store
(``stack.ome.zarr``, level 0 of each pyramid) with ``zarr``, or, in a build written
without the store, from its TIFF stacks through tifffile's Zarr interface. Nothing is
read until indexed. The grid, the names of the layers and of the materials come from
``manifest.json``.

Conventions: volumes are indexed ``(z, y, x)``; points are ``(x, y, z)`` in millimetres;
voxel ``(z, y, x)`` has its centre at ``origin_mm + (x * vx, y * vy, z * vz)``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from shellvox.errors import InputError, opt
from shellvox.voxel.grid import GridSpec

if TYPE_CHECKING:
    from shellvox.voxel.colour import SoftProof

STORE = "stack.ome.zarr"


class Samples(NamedTuple):
    """What a build holds at given points (:meth:`Build.sample`).

    Attributes
    ----------
    inside : (N,) bool
        The point lies in the grid (its nearest voxel centre is a voxel of it).
    index_zyx : (N, 3) int64
        The nearest voxel ``(z, y, x)`` (clipped to the grid where `inside` is False).
    layer : (N,) uint8
        Its layer: 0 outside the part, 1..K the bands from the outside in, K + 1 the core
        (0 where `inside` is False).
    colour : (N, C) uint8
        Its colour, sRGB (and alpha with ``C == 4``); 0 outside the colour layers.
    material : (N,) uint8 or None
        Its material index (0: void), where the build has materials.
    """

    inside: NDArray[np.bool_]
    index_zyx: NDArray[np.int64]
    layer: NDArray[np.uint8]
    colour: NDArray[np.uint8]
    material: NDArray[np.uint8] | None


class ChannelsLast:
    """A lazy ``(Z, Y, X, C)`` view of a ``(C, Z, Y, X)`` array (the store's colour).

    Indexing with integers and slices reads only what it selects: ``view[z]`` is the
    ``(Y, X, C)`` slice ``z``.
    """

    def __init__(self, planar: Any) -> None:
        self._planar = planar
        channels, *rest = planar.shape
        self.shape: tuple[int, ...] = (*rest, channels)
        self.dtype = np.dtype(planar.dtype)
        self.ndim = 4

    def __getitem__(self, key: Any) -> NDArray[Any]:
        key = key if isinstance(key, tuple) else (key,)
        if any(k is Ellipsis for k in key):
            at = next(i for i, k in enumerate(key) if k is Ellipsis)
            key = key[:at] + (slice(None),) * (4 - len(key) + 1) + key[at + 1 :]
        key = key + (slice(None),) * (4 - len(key))
        if len(key) != 4 or not all(isinstance(k, int | np.integer | slice) for k in key):
            raise IndexError("index the colour with integers and slices (z, y, x, c)")
        read = np.asarray(self._planar[(key[3], *key[:3])])
        channel_axis = 0 if isinstance(key[3], slice) else None
        if channel_axis is None:
            return read
        return np.moveaxis(read, 0, -1)

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        whole = self[...]
        return whole if dtype is None else whole.astype(dtype)

    def __repr__(self) -> str:
        return f"<colour (z, y, x, c) {self.shape} {self.dtype}, read lazily>"


@dataclass(frozen=True, eq=False)
class Build:
    """A finished build: its voxels as lazy arrays and the grid that places them.

    Attributes
    ----------
    folder : Path
    manifest : dict
        ``manifest.json``.
    grid : GridSpec
        Origin (the centre of voxel ``(0, 0, 0)``), voxel size and shape ``(Z, Y, X)``.
    layers : (Z, Y, X) uint8 array, read lazily
        Layer per voxel: 0 outside, 1..K the bands, K + 1 the core.
    colour : (Z, Y, X, C) uint8 array, read lazily
        sRGB (+ alpha) per voxel; 0 outside the colour layers.
    materials : (Z, Y, X) uint8 array, read lazily, or None
        Material index per voxel (0: void), where the build has materials.
    layer_names : tuple of str
        Name of each layer index (``outside``, ``colour_1``, ``backing_2``, ..., ``core``).
    material_names : dict of int to str
        Name of each material index the build holds (0: void).
    source : str
        Where the voxels are read from: ``"zarr"`` (the store) or ``"tiff"``.
    """

    folder: Path
    manifest: dict[str, Any]
    grid: GridSpec
    layers: Any
    colour: Any
    materials: Any
    layer_names: tuple[str, ...]
    material_names: dict[int, str]
    source: str

    def __repr__(self) -> str:
        """One line: the folder, grid, voxel size, printer and files (not the manifest)."""
        from shellvox.output import manifest_line

        line = manifest_line(self.manifest)
        return f"Build({str(self.folder)!r}, {line}, source={self.source!r})"

    @property
    def voxel_mm(self) -> tuple[float, float, float]:
        """Voxel size ``(vx, vy, vz)``, mm."""
        return self.grid.voxel_mm

    @property
    def origin_mm(self) -> tuple[float, float, float]:
        """Centre ``(x, y, z)`` of voxel ``(0, 0, 0)``, mm."""
        return self.grid.origin_mm

    @property
    def shape_zyx(self) -> tuple[int, int, int]:
        """Voxels ``(Z, Y, X)``."""
        return self.grid.shape_zyx

    def sample(self, points_mm: ArrayLike) -> Samples:
        """Return the layer, colour and material of the voxels nearest to `points_mm`.

        Parameters
        ----------
        points_mm : (N, 3) array_like of float, mm
            Points ``(x, y, z)`` in the build's frame (the model's, as built).

        Returns
        -------
        Samples
            Only the chunks holding the points are read.

        Examples
        --------
        >>> import shellvox
        >>> options = shellvox.BuildOptions(voxel_size_mm=(0.2, 0.2, 0.2), formats=("zarr",))
        >>> build = shellvox.build(shellvox.data.colour_target(), "out", options).open()
        >>> centre = build.grid.index_to_world([[n // 2 for n in build.shape_zyx]])[0]
        >>> samples = build.sample([centre, [1e3, 0.0, 0.0]])
        >>> samples.inside.tolist(), build.layer_names[samples.layer[0]]
        ([True, False], 'core')
        """
        points = np.asarray(points_mm, np.float64).reshape(-1, 3)
        nearest = np.rint(self.grid.world_to_index(points))
        shape = np.asarray(self.grid.shape_zyx)
        inside = np.all(np.isfinite(nearest) & (nearest >= 0) & (nearest < shape), axis=1)
        index = np.clip(np.nan_to_num(nearest), 0, shape - 1).astype(np.int64)
        z, y, x = index.T
        layer = _points(self.layers, (z, y, x))
        channels = self.colour.shape[-1]
        planar = self.source == "zarr"
        colour = np.stack(
            [
                _points(self.colour_planar, (np.full_like(z, c), z, y, x))
                if planar
                else _points(self.colour, (z, y, x, np.full_like(z, c)))
                for c in range(channels)
            ],
            axis=-1,
        )
        material = None if self.materials is None else _points(self.materials, (z, y, x))
        layer[~inside] = 0
        colour[~inside] = 0
        if material is not None:
            material[~inside] = 0
        return Samples(inside, index, layer, colour, material)

    def soft_proof(
        self, points_mm: ArrayLike | None = None, normals: ArrayLike | None = None
    ) -> SoftProof:
        """Return the build's soft proof: predicted printed colour and errors, as arrays.

        Parameters
        ----------
        points_mm : (M, 3) array_like of float, mm, optional
            Surface points ``(x, y, z)`` in the build's frame; None: the samples the
            build predicted (``proof.ply``).
        normals : (M, 3) or (3,) array_like of float, optional
            The points' outward normals (or one direction towards a viewer); needed
            with `points_mm`. Only samples facing the same side are interpolated
            (:meth:`shellvox.voxel.colour.SoftProof.at`).

        Returns
        -------
        SoftProof
            ``target_lab``, ``aim_lab``, ``predicted_lab`` (CIELAB of the optics' white,
            D50), ``total_de``, ``gamut_de``, ``reproduction_de`` (CIEDE2000) per point;
            NaN where no sample is near. ``srgb("predicted")`` gives displayable colours.

        Raises
        ------
        InputError
            The build has no soft proof (built without materials, with
            ``report_samples=0``, or before shellvox wrote one), its ``proof.ply``
            cannot be read, or the points or normals are not finite ``(M, 3)`` arrays.

        Examples
        --------
        >>> import numpy as np, shellvox
        >>> options = shellvox.BuildOptions(voxel_size_mm=(0.2, 0.2, 0.2), formats=("zarr",))
        >>> build = shellvox.build(shellvox.data.colour_target(), "proofed", options).open()
        >>> samples = build.soft_proof()
        >>> len(samples) >= options.report_samples, samples.optics
        (True, 'assumed')
        >>> first = build.soft_proof(samples.points_mm[:1], samples.normals[:1])
        >>> bool(np.allclose(first.predicted_lab, samples.predicted_lab[:1], atol=1e-3))
        True
        """
        from shellvox.output import PROOF_FILE, read_proof_ply

        path = self.folder / PROOF_FILE
        if PROOF_FILE not in self.manifest.get("files", {}):
            raise InputError(
                self.folder,
                "has no soft proof (proof.ply)",
                f"rebuild it with materials and {opt('report_samples')} above 0 (the defaults)",
            )
        try:
            proof = read_proof_ply(path)
        except (OSError, ValueError) as error:
            raise InputError(path, f"cannot be read ({error})", "rebuild it") from None
        if points_mm is None:
            return proof
        points = _finite_rows(points_mm, "points_mm", "(M, 3) points (x, y, z) in mm")
        if normals is None:
            raise InputError(
                "normals", "is missing", "give the points' normals, or one view direction"
            )
        directions = _finite_rows(normals, "normals", "(M, 3) normals or one (3,) direction")
        if len(directions) not in (1, len(points)):
            raise InputError(
                "normals",
                f"holds {len(directions)} rows for {len(points)} points",
                "give one normal per point, or one direction",
            )
        if not (np.linalg.norm(directions, axis=1) > 0).all():
            raise InputError("normals", "holds a zero vector", "give non-zero directions")
        return proof.at(points, directions)

    @property
    def colour_planar(self) -> Any:
        """The colour as the store holds it, ``(C, Z, Y, X)`` (OME-Zarr's axis order)."""
        planar = getattr(self.colour, "_planar", None)
        if planar is None:
            raise AttributeError("a build read from its TIFF stacks has no planar colour")
        return planar


def _finite_rows(values: ArrayLike, name: str, fix: str) -> NDArray[np.float64]:
    """Return `values` as finite ``(M, 3)`` float64 rows, or say in one line why not."""
    try:
        rows = np.asarray(values, np.float64)
    except (TypeError, ValueError):
        raise InputError(name, "is not an array of numbers", f"give {fix}") from None
    if rows.ndim == 1:
        rows = rows[None, :]
    if rows.ndim != 2 or rows.shape[1] != 3:
        raise InputError(name, f"has shape {np.shape(values)}", f"give {fix}")
    if not np.isfinite(rows).all():
        raise InputError(name, "holds NaN or infinite values", f"give {fix}")
    return rows


def _points(array: Any, index: tuple[NDArray[np.int64], ...]) -> NDArray[Any]:
    """Read the elements at `index` (one array per axis) of a zarr or numpy-like array."""
    if not len(index[0]):
        return np.zeros(0, np.dtype(array.dtype))
    values: NDArray[Any] = np.asarray(array.get_coordinate_selection(index))
    return values.copy()


def open_build(folder: str | Path) -> Build:
    """Open a finished build's voxels as lazy arrays.

    Parameters
    ----------
    folder : path
        The output folder of ``shellvox build`` (:func:`shellvox.build`): its
        ``manifest.json`` and ``stack.ome.zarr`` (or, without the store, its TIFF stacks).

    Returns
    -------
    Build

    Raises
    ------
    InputError
        Not a finished build, or one with neither the store nor the TIFF stacks.

    Examples
    --------
    >>> import shellvox
    >>> options = shellvox.BuildOptions(voxel_size_mm=(0.2, 0.2, 0.2), formats=("zarr",))
    >>> result = shellvox.build(shellvox.data.colour_target(), "out", options)
    >>> build = shellvox.open_build("out")
    >>> build.layers.shape == build.shape_zyx, build.voxel_mm
    (True, (0.2, 0.2, 0.2))
    >>> middle = build.layers[build.shape_zyx[0] // 2]  # one z slice, read now
    >>> middle.dtype, sorted(set(middle.ravel().tolist()))[:2]
    (dtype('uint8'), [0, 1])
    >>> build.material_names[1]
    'VeroCyan-V'
    """
    root = Path(folder)
    manifest_path = root / "manifest.json"
    try:
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        grid = manifest["grid"]
        spec = GridSpec(
            tuple(grid["origin_mm"]), tuple(grid["voxel_size_mm"]), tuple(grid["shape_zyx"])
        )
        layer_names = tuple(str(layer["name"]) for layer in manifest["layers"])
        materials = {int(m["index"]): str(m["name"]) for m in manifest.get("materials", [])}
    except FileNotFoundError:
        raise InputError(
            root, "has no manifest.json", "give the output folder of a shellvox build"
        ) from None
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise InputError(
            manifest_path, f"cannot be read ({type(error).__name__}: {error})", "rebuild it"
        ) from None
    files = manifest.get("files", {})
    if any(name.startswith(f"{STORE}/") for name in files):
        layers, colour, material = _from_store(root / STORE)
        source = "zarr"
    elif "layers.tif" in files and "colour.tif" in files:
        layers, colour, material = _from_tiffs(root, "materials.tif" in files)
        source = "tiff"
    else:
        raise InputError(
            root,
            "holds neither stack.ome.zarr nor the TIFF stacks",
            f"build with {opt('formats', ('zarr',))}",
        )
    for name, array in (("layers", layers), ("colour", colour)):
        if tuple(array.shape[:3]) != spec.shape_zyx:
            raise InputError(
                root,
                f"its {name} are {tuple(array.shape)}, the manifest's grid {spec.shape_zyx}",
                "rebuild it",
            )
    return Build(root, manifest, spec, layers, colour, material, layer_names, materials, source)


def _from_store(store: Path) -> tuple[Any, Any, Any]:
    import zarr

    try:
        group = zarr.open_group(str(store), mode="r")
        layers = group["labels/layers/0"]
        colour = ChannelsLast(group["0"])
        labels = group["labels"]
        materials = group["labels/materials/0"] if "materials" in labels else None  # type: ignore[operator]
    except (OSError, KeyError, ValueError) as error:
        raise InputError(store, f"cannot be read ({error})", "rebuild it") from None
    return layers, colour, materials


def _from_tiffs(root: Path, with_materials: bool) -> tuple[Any, Any, Any]:
    import tifffile
    import zarr

    def array(name: str) -> Any:
        try:
            return zarr.open_array(tifffile.imread(root / name, aszarr=True), mode="r")
        except (OSError, ValueError, KeyError) as error:
            raise InputError(root / name, f"cannot be read ({error})", "rebuild it") from None

    return (
        array("layers.tif"),
        array("colour.tif"),
        array("materials.tif") if with_materials else None,
    )
