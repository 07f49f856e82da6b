"""VRML 2.0 (``.wrl``): indexed face sets with per-vertex or per-face colour or a texture.

The exchange format of colour printing services and printer front ends. The file is
parsed by :mod:`shellvox.loading.vrml._parse`; this module walks the scene graph
(``Transform`` with ``translation rotation scale scaleOrientation center``, ``Group``,
``Anchor``, ``Collision``, ``Billboard`` as a group, ``Switch`` by ``whichChoice``, the
first ``LOD`` level, ``DEF``/``USE``) and reads every ``Shape`` whose geometry is an
``IndexedFaceSet`` (polygons fanned into triangles; ``ccw FALSE`` and mirroring
transforms keep faces outward). Its colour, per ISO/IEC 14772-1 6.23 and 4.14:

- ``ImageTexture`` with ``texCoord`` (``texCoordIndex``, else ``coordIndex``): the
  texture (``repeatS``/``repeatT``: repeat or clamp), first usable ``url`` under the path
  policy of :mod:`shellvox.loading._references`; its colour replaces the material's
  ``diffuseColor`` and a ``Color`` node beside it is ignored, as the spec says for RGB
  textures (greyscale "intensity" textures, which VRML multiplies with
  ``diffuseColor``, are read as RGB too);
- else ``Color``: per vertex (``colorPerVertex TRUE``, the default; ``colorIndex`` laid
  out like ``coordIndex``, else ``coordIndex``) or per face (``colorIndex`` one per face,
  else in face order);
- else ``Material`` ``diffuseColor`` (default 0.8 grey); without a material, no colour.

Colours are taken as sRGB values; ``transparency`` becomes alpha ``1 - transparency``.
VRML's unit is nominally the metre, but printing services and exporters use VRML in
millimetres, so a ``.wrl`` is read as millimetres like the other unit-less formats
(``--units m`` for a file in metres). What is not read (other geometry nodes,
``PixelTexture``, ``TextureTransform``, ``Inline``, ``PROTO`` instances) is named in a
warning.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.config import LoadOptions
from shellvox.errors import InputError, warn
from shellvox.loading._combine import combine_parts
from shellvox.loading._images import TextureRef, read_textures
from shellvox.loading._references import check_inside, is_file
from shellvox.loading.vrml._parse import FIX, Node, Value, parse_vrml
from shellvox.model import ColouredMesh, Material, WrapMode

GROUPS = ("Group", "Anchor", "Collision", "Billboard")
#: Nodes without geometry or colour, skipped silently.
HARMLESS = {
    "Viewpoint", "NavigationInfo", "WorldInfo", "Background", "Fog", "DirectionalLight",
    "PointLight", "SpotLight", "TimeSensor", "Sound", "AudioClip", "Script", "ProximitySensor",
    "TouchSensor", "VisibilitySensor", "CylinderSensor", "PlaneSensor", "SphereSensor",
    "PositionInterpolator", "OrientationInterpolator", "ColorInterpolator",
    "ScalarInterpolator", "CoordinateInterpolator", "NormalInterpolator",
    # property nodes DEFined at the top level to be USEd in shapes
    "Appearance", "Material", "ImageTexture", "Coordinate", "Color", "TextureCoordinate",
    "Normal",
}  # fmt: skip


def read_vrml(path: Path, options: LoadOptions) -> ColouredMesh:
    """Read a VRML 2.0 file into an unmerged mesh in file units.

    Parameters
    ----------
    path : Path
        The ``.wrl`` file.
    options : LoadOptions
        ``colour`` replaces a missing texture (with a warning); ``force`` reads textures
        outside the model's folder and lifts the pixel budget.

    Returns
    -------
    ColouredMesh
        Every face set, transformed, with one colour source (see the module docstring).

    Raises
    ------
    InputError
        The file is not VRML 2.0, is malformed, or has no face set.
    """
    try:
        return _read_vrml(path, options)
    except InputError:
        raise
    except (ValueError, IndexError, TypeError) as error:  # a safety net: checks name the rest
        raise InputError(path, f"is malformed ({type(error).__name__}: {error})", FIX) from None
    except RecursionError:  # the parser and the scene walk recurse once per level
        raise InputError(path, "nests its nodes or lists too deeply to read", FIX) from None


def _read_vrml(path: Path, options: LoadOptions) -> ColouredMesh:
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    scene = parse_vrml(path, text)
    walk = _Walk(path, options)
    for node in scene.nodes:
        walk.node(node, np.eye(4), 0)
    unread = sorted(walk.unread | {s for s in scene.skipped if s != "ROUTE"})
    if unread:
        warn(
            f"{path}: {', '.join(unread)} are not read (no geometry or colour taken from them)",
        )
    if not walk.parts:
        raise InputError(path, "has no IndexedFaceSet with faces", "export the model as meshes")
    return combine_parts(path, walk.resolve_textures())


def _number(value: Value, default: float) -> float:
    if isinstance(value, np.ndarray) and value.size == 1:
        return float(value[0])
    return float(value) if isinstance(value, float) else default


def _vector(path: Path, node: Node, name: str, default: list[float]) -> NDArray[np.float64]:
    value = node.fields.get(name)
    if value is None:
        return np.array(default, dtype=np.float64)
    array = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if array.shape != (len(default),) or not np.isfinite(array).all():
        raise InputError(path, f"{node.type} {name} is {value!r}, not {len(default)} numbers", FIX)
    return array


def _rotation(axis_angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """4x4 rotation about ``axis_angle[:3]`` by ``axis_angle[3]`` radians (Rodrigues)."""
    axis, angle = axis_angle[:3], axis_angle[3]
    norm = np.linalg.norm(axis)
    matrix = np.eye(4)
    if norm == 0 or angle == 0:
        return matrix
    x, y, z = axis / norm
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    matrix[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    return matrix


def _transform(path: Path, node: Node) -> NDArray[np.float64]:
    """``T * C * R * SR * S * -SR * -C`` of a Transform node (ISO/IEC 14772-1 6.52)."""
    translate, centre = np.eye(4), np.eye(4)
    translate[:3, 3] = _vector(path, node, "translation", [0, 0, 0])
    centre[:3, 3] = _vector(path, node, "center", [0, 0, 0])
    scale = np.diag([*_vector(path, node, "scale", [1, 1, 1]), 1.0])
    rotation = _rotation(_vector(path, node, "rotation", [0, 0, 1, 0]))
    orient = _rotation(_vector(path, node, "scaleOrientation", [0, 0, 1, 0]))
    matrix: NDArray[np.float64] = (
        translate @ centre @ rotation @ orient @ scale @ orient.T @ np.linalg.inv(centre)
    )
    return matrix


def _children(node: Node, name: str = "children") -> list[Node]:
    value = node.fields.get(name)
    items = value if isinstance(value, list) else [value]
    return [item for item in items if isinstance(item, Node)]


def _fan(index: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Fan triangulation of ``-1``-separated polygons.

    Returns the positions in ``index`` of each triangle's corners ``(T, 3)`` and each
    triangle's polygon ``(T,)``.
    """
    ends = np.flatnonzero(index < 0)
    if len(index) and index[-1] >= 0:
        ends = np.append(ends, len(index))
    starts = np.r_[0, ends[:-1] + 1] if len(ends) else np.zeros(0, np.int64)
    counts = np.maximum(ends - starts - 2, 0)  # triangles per polygon
    polygon = np.repeat(np.arange(len(starts)), counts)
    step = np.arange(len(polygon)) - np.repeat(np.cumsum(counts) - counts, counts)
    first = starts[polygon]
    corners = np.stack([first, first + step + 1, first + step + 2], axis=1)
    return corners.astype(np.int64), polygon.astype(np.int64)


class _Walk:
    """Walk the scene graph collecting face sets as :func:`combine_parts` parts."""

    def __init__(self, path: Path, options: LoadOptions) -> None:
        self.path, self.options = path, options
        self.parts: list[dict[str, Any]] = []
        self.unread: set[str] = set()
        self.textures: dict[Path | None, int] = {}  # texture file -> index of its ref
        self.refs: list[TextureRef] = []

    def node(self, node: Node, matrix: NDArray[np.float64], depth: int) -> None:
        if depth > 256:
            raise InputError(self.path, "nests nodes more than 256 deep (a USE cycle?)", FIX)
        kind = node.type
        if kind == "Transform":
            matrix = matrix @ _transform(self.path, node)
        if kind == "Transform" or kind in GROUPS:
            children = _children(node)
        elif kind == "Switch":
            choice = int(_number(node.fields.get("whichChoice"), -1))
            options = _children(node, "choice")
            children = [options[choice]] if 0 <= choice < len(options) else []
        elif kind == "LOD":
            children = _children(node, "level")[:1]
        elif kind == "Shape":
            self.shape(node, matrix)
            return
        else:
            if kind not in HARMLESS:
                self.unread.add(kind)
            return
        for child in children:
            self.node(child, matrix, depth + 1)

    def shape(self, shape: Node, matrix: NDArray[np.float64]) -> None:
        geometry = shape.fields.get("geometry")
        if not isinstance(geometry, Node):
            return
        if geometry.type != "IndexedFaceSet":
            self.unread.add(geometry.type)
            return
        appearance = shape.fields.get("appearance")
        material = texture = None
        if isinstance(appearance, Node):
            material = appearance.fields.get("material")
            texture = appearance.fields.get("texture")
            if isinstance(appearance.fields.get("textureTransform"), Node):
                self.unread.add("TextureTransform")
        part = self.face_set(geometry, matrix)
        if part is None:
            return
        faces, corner_pos, polygon = part.pop("_corners")
        alpha = 1.0
        if isinstance(material, Node):
            alpha = 1.0 - _number(material.fields.get("transparency"), 0.0)
            diffuse = _vector(self.path, material, "diffuseColor", [0.8, 0.8, 0.8])
            part["rgba"] = np.broadcast_to(_rgba(diffuse[None], alpha), (len(faces), 3, 4))
        if isinstance(texture, Node) and texture.type != "ImageTexture":
            self.unread.add(texture.type)
        elif isinstance(texture, Node) and isinstance(geometry.fields.get("texCoord"), Node):
            uv = self.texcoords(geometry, corner_pos)
            if uv is not None:
                part["uv"], part["_texture"] = uv, self.texture(texture, alpha)
                self.parts.append(part)
                return
        elif isinstance(texture, Node):
            self.unread.add("ImageTexture without texCoord")
        colour = geometry.fields.get("color")
        if isinstance(colour, Node):
            table = _points(self.path, colour, "color", 3)
            per_vertex = geometry.fields.get("colorPerVertex", True) is not False
            index = _laid_out(
                self.path, geometry, "colorIndex", per_vertex, corner_pos if per_vertex else polygon
            )
            if per_vertex:
                ids = (index if len(index) else _index(geometry, "coordIndex"))[corner_pos]
            else:
                ids = index[polygon] if len(index) else polygon
                ids = np.repeat(ids[:, None], 3, axis=1)
            part["rgba"] = _rgba(table[_checked(self.path, ids, len(table), "color")], alpha)
        self.parts.append(part)

    def face_set(self, node: Node, matrix: NDArray[np.float64]) -> dict[str, Any] | None:
        coord = node.fields.get("coord")
        if not isinstance(coord, Node):
            return None
        points = _points(self.path, coord, "point", 3)
        index = _index(node, "coordIndex")
        corner_pos, polygon = _fan(index)
        if len(corner_pos) == 0:
            return None
        faces = _checked(self.path, index[corner_pos], len(points), "coord")
        if (node.fields.get("ccw", True) is False) != (np.linalg.det(matrix[:3, :3]) < 0):
            faces, corner_pos = faces[:, ::-1], corner_pos[:, ::-1]
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused by load_model
            vertices = points @ matrix[:3, :3].T + matrix[:3, 3]
        return {"vertices": vertices, "faces": faces, "_corners": (faces, corner_pos, polygon)}

    def texcoords(self, node: Node, corner_pos: NDArray[np.int64]) -> NDArray[np.float64] | None:
        coord = node.fields.get("texCoord")
        assert isinstance(coord, Node)
        table = _points(self.path, coord, "point", 2)
        index = _laid_out(self.path, node, "texCoordIndex", True, corner_pos)
        ids = (index if len(index) else _index(node, "coordIndex"))[corner_pos]
        uv: NDArray[np.float64] = table[_checked(self.path, ids, len(table), "texCoord")]
        return uv

    def texture(self, node: Node, alpha: float) -> tuple[int, tuple[WrapMode, WrapMode], float]:
        urls = node.fields.get("url")
        names = [u for u in (urls if isinstance(urls, list) else [urls]) if isinstance(u, str)]
        files = [self.path.parent / n for n in names if "://" not in n]
        found = next((f for f in files if is_file(f)), None)
        if found is not None:
            what = f"texture {found.name!r}"
            found = check_inside(self.path, found, what, force=self.options.force)
        if found not in self.textures:
            label = f"texture {names[0]!r}" if names else "an ImageTexture without url"
            self.textures[found] = len(self.refs)
            self.refs.append(TextureRef(self.path, label, found, "put the image beside the .wrl"))
        wrap: tuple[WrapMode, WrapMode] = (
            "clamp" if node.fields.get("repeatS") is False else "repeat",
            "clamp" if node.fields.get("repeatT") is False else "repeat",
        )
        return self.textures[found], wrap, alpha

    def resolve_textures(self) -> list[dict[str, Any]]:
        """Decode the textures (pixel budget over all) and turn parts into materials."""
        images = read_textures(self.refs, colour=self.options.colour, force=self.options.force)
        for part in self.parts:
            if "_texture" not in part:
                continue
            index, wrap, alpha = part.pop("_texture")
            uv = part.pop("uv")
            image = images[index]
            if image is None:  # replaced by --colour; read_textures warned
                assert self.options.colour is not None
                colour = np.asarray(self.options.colour, np.uint8)
                part["rgba"] = np.broadcast_to(colour, (len(part["faces"]), 3, 4))
                continue
            part.pop("rgba", None)
            part["uv"] = uv
            factor = np.array([1.0, 1.0, 1.0, alpha])
            part["material"] = Material(self.refs[index].label, factor, image, wrap)
        return self.parts


def _points(path: Path, node: Node, name: str, width: int) -> NDArray[np.float64]:
    value = node.fields.get(name)
    array = np.asarray(value if isinstance(value, np.ndarray) else [], dtype=np.float64)
    if array.size % width or not np.isfinite(array).all():
        raise InputError(
            path, f"{node.type} {name} holds {array.size} numbers, not groups of {width}", FIX
        )
    return array.reshape(-1, width)


def _index(node: Node, name: str) -> NDArray[np.int64]:
    value = node.fields.get(name)
    if isinstance(value, float):
        value = np.array([value])
    array = np.asarray(value if isinstance(value, np.ndarray) else [], dtype=np.float64)
    return np.rint(array).astype(np.int64)


def _laid_out(
    path: Path, node: Node, name: str, per_vertex: bool, used: NDArray[np.int64]
) -> NDArray[np.int64]:
    """Return an index field, checked to be laid out like ``coordIndex`` (or per face)."""
    index = _index(node, name)
    if len(index) and used.size and used.max() >= len(index):
        layout = "like coordIndex" if per_vertex else "one per face"
        raise InputError(
            path, f"{name} has {len(index)} entries, fewer than its layout ({layout}) needs", FIX
        )
    return index


def _checked(path: Path, ids: NDArray[np.int64], size: int, what: str) -> NDArray[np.int64]:
    if ids.size and (ids.min() < 0 or ids.max() >= size):
        raise InputError(
            path, f"an index into {what} is out of range (0..{size - 1})", "export it again"
        )
    return ids


def _rgba(rgb: NDArray[np.float64], alpha: float) -> NDArray[np.uint8]:
    """``(..., 3)`` colours in ``[0, 1]`` (sRGB values) and an alpha as ``(..., 4) uint8``."""
    values = np.concatenate([rgb, np.full((*rgb.shape[:-1], 1), alpha)], axis=-1)
    rgba: NDArray[np.uint8] = np.rint(np.clip(values, 0.0, 1.0) * 255).astype(np.uint8)
    return rgba
