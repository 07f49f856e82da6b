"""glTF texture coordinates: the set a material chooses and ``KHR_texture_transform``.

A ``textureInfo`` names its coordinate set (``texCoord``, ``TEXCOORD_n``); the
``KHR_texture_transform`` extension moves the coordinates before sampling: ``uv' = T R S
uv`` with ``T`` the ``offset``, ``R = [[cos r, sin r], [-sin r, cos r]]`` the
``rotation`` ``r`` and ``S`` the ``scale``, all in glTF's texture space (origin at the
top-left, ``v`` down), and its own ``texCoord`` overrides the textureInfo's. The result
is converted once to shellvox's convention (``v`` up). Reference: glTF 2.0 3.9.2 and
the KHR_texture_transform extension specification.

``TEXCOORD_0`` comes from trimesh (which has already flipped ``v``); other sets are read
here from their accessor (float, or normalised unsigned byte or short).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.errors import InputError

FIX = "the file is truncated or corrupt; export it again"
#: Component type -> (numpy dtype, divisor of normalised integers).
UV_COMPONENTS = {5126: ("<f4", 1.0), 5121: ("u1", 255.0), 5123: ("<u2", 65535.0)}


def texture_transform(
    path: Path, material: str, info: dict[str, Any]
) -> tuple[NDArray[np.float64], int]:
    """Return a textureInfo's transform ``(3, 3)`` (glTF texture space) and coordinate set.

    Parameters
    ----------
    path : Path
        The model, for messages.
    material : str
        Material name, for messages.
    info : dict
        The ``textureInfo`` (``baseColorTexture`` or ``diffuseTexture``).

    Returns
    -------
    matrix : (3, 3) float64
        Homogeneous 2D transform applied to ``(u, v, 1)``.
    tex_coord : int
        The coordinate set ``n`` of ``TEXCOORD_n``.

    Examples
    --------
    >>> matrix, n = texture_transform(
    ...     Path("m.glb"), "m", {"extensions": {"KHR_texture_transform": {"offset": [0.5, 0]}}}
    ... )
    >>> (matrix @ [0.25, 0.25, 1]).tolist(), n
    ([0.75, 0.25, 1.0], 0)
    """
    tex_coord = info.get("texCoord", 0)
    extension = info.get("extensions", {}).get("KHR_texture_transform")
    matrix = np.eye(3)
    if isinstance(extension, dict):
        offset = _numbers(path, material, "offset", extension.get("offset", [0, 0]), 2)
        rotation = _numbers(path, material, "rotation", [extension.get("rotation", 0)], 1)[0]
        scale = _numbers(path, material, "scale", extension.get("scale", [1, 1]), 2)
        cos, sin = np.cos(rotation), np.sin(rotation)
        translate = np.array([[1, 0, offset[0]], [0, 1, offset[1]], [0, 0, 1]])
        rotate = np.array([[cos, sin, 0], [-sin, cos, 0], [0, 0, 1]])
        matrix = translate @ rotate @ np.diag([scale[0], scale[1], 1.0])
        tex_coord = extension.get("texCoord", tex_coord)
    elif extension is not None:
        raise InputError(path, f"material {material!r} has a malformed KHR_texture_transform", FIX)
    if not isinstance(tex_coord, int) or isinstance(tex_coord, bool) or tex_coord < 0:
        raise InputError(path, f"material {material!r} has a malformed texCoord {tex_coord!r}", FIX)
    return matrix, tex_coord


def _numbers(path: Path, material: str, name: str, value: Any, size: int) -> NDArray[np.float64]:
    try:
        array = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        array = np.array([np.nan])
    if array.shape != (size,) or not np.isfinite(array).all():
        raise InputError(
            path,
            f"material {material!r}: KHR_texture_transform {name} is {value!r}, "
            f"not {size} number{'s' if size > 1 else ''}",
            FIX,
        )
    return array


def primitive_uv(
    path: Path,
    tree: dict[str, Any],
    buffers: list[Path | bytes | None],
    primitive: dict[str, Any],
    tex_coord: int,
    matrix: NDArray[np.float64],
    trimesh_uv: NDArray[np.float64] | None,
    n_vertices: int,
) -> tuple[NDArray[np.float64] | None, str | None]:
    """Texture coordinates of a primitive's vertices, transformed, in shellvox's convention.

    Parameters
    ----------
    path : Path
        The model, for messages.
    tree : dict
        The glTF document.
    buffers : list of (Path or bytes or None)
        Where each buffer's bytes are (checked by the loader).
    primitive : dict
        The mesh primitive.
    tex_coord : int
        The coordinate set to use.
    matrix : (3, 3) float64
        The ``KHR_texture_transform`` (identity without one).
    trimesh_uv : (V, 2) float64 or None
        trimesh's ``TEXCOORD_0`` (``v`` already flipped up).
    n_vertices : int
        Vertices of the primitive as loaded.

    Returns
    -------
    uv : (V, 2) float64 or None
        ``u`` right, ``v`` up; None when the set cannot be used.
    problem : str or None
        Why not, for the warning.
    """
    name = f"TEXCOORD_{tex_coord}"
    if tex_coord == 0 and trimesh_uv is not None and len(trimesh_uv) == n_vertices:
        gltf = np.asarray(trimesh_uv, dtype=np.float64) * [1.0, -1.0] + [0.0, 1.0]
    else:
        index = primitive.get("attributes", {}).get(name)
        if not isinstance(index, int) or not 0 <= index < len(tree.get("accessors", [])):
            return None, f"is on a primitive without {name}"
        gltf = _read_vec2(path, tree, buffers, index, name)
        if len(gltf) != n_vertices:
            return None, f"has {len(gltf)} {name} values for {n_vertices} vertices"
    moved = gltf @ matrix[:2, :2].T + matrix[:2, 2]
    uv: NDArray[np.float64] = moved * [1.0, -1.0] + [0.0, 1.0]
    return uv, None


def _read_vec2(
    path: Path, tree: dict[str, Any], buffers: list[Path | bytes | None], index: int, name: str
) -> NDArray[np.float64]:
    """Read a ``VEC2`` accessor of texture coordinates (its view is checked by the loader)."""
    accessor = tree["accessors"][index]
    component = UV_COMPONENTS.get(accessor.get("componentType", 0))
    if accessor.get("type") != "VEC2" or component is None or "sparse" in accessor:
        raise InputError(
            path,
            f"{name} (accessor {index}) is not VEC2 of float, unsigned byte or unsigned short "
            "(or is sparse)",
            "export the texture coordinates as float VEC2",
        )
    dtype, divisor = np.dtype(component[0]), component[1]
    count = accessor["count"]
    if "bufferView" not in accessor:
        return np.zeros((count, 2))
    view = tree["bufferViews"][accessor["bufferView"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride", 2 * dtype.itemsize)
    length = (count - 1) * stride + 2 * dtype.itemsize if count else 0
    source = buffers[view["buffer"]]
    if isinstance(source, Path):
        with source.open("rb") as handle:
            handle.seek(start)
            data = handle.read(length)
    else:
        data = (source or b"")[start : start + length]
    if len(data) < length:
        raise InputError(path, f"{name} (accessor {index}) runs past its buffer", FIX)
    values: NDArray[Any] = np.ndarray(
        (count, 2), dtype=dtype, buffer=data, strides=(stride, dtype.itemsize)
    )
    return values.astype(np.float64) / divisor
