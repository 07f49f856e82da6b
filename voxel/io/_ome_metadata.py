"""The OME-Zarr 0.5 (NGFF) metadata of a stack's store: multiscales, labels, omero.

What :class:`shellvox.voxel.io._zarr_writer.OmeZarrWriter` puts in the ``zarr.json`` attributes
(under ``"ome"``) of the store's groups:

- the root (the colour image): ``multiscales`` with axes ``c`` (channel) and ``z, y, x``
  (space, ``millimeter``), one dataset per level (``"0"``, ``"1"``, ...) whose ``scale`` is
  its voxel size ``(z, y, x)`` mm and ``translation`` the centre of its voxel ``(0, 0, 0)``
  (for level 0 the grid's ``origin_mm``; a block of ``f`` voxels has its centre
  ``(f - 1) / 2`` voxels further); ``omero`` channels red, green, blue (and alpha);
- ``labels``: the list of label images (``materials``, ``layers``);
- ``labels/NAME``: the same multiscales without the channel axis, and ``image-label``
  with ``colors`` (``label-value``, RGBA 0..255) and ``properties`` (``label-value``
  and what each value is) of every value the image may hold.

References
----------
.. [1] OME-NGFF 0.5, https://ngff.openmicroscopy.org/0.5/
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

#: The NGFF version written.
NGFF_VERSION = "0.5"


@dataclass(frozen=True)
class LabelValue:
    """One value of a label image: its display colour and what it stands for.

    Parameters
    ----------
    value : int
        The label (0..255).
    rgba : (4,) int, 0..255
        Display colour.
    properties : mapping
        JSON-ready facts (``name``, ``role``, ...), written with ``label-value``.
    """

    value: int
    rgba: tuple[int, int, int, int]
    properties: Mapping[str, Any] = field(default_factory=dict)


def level_transforms(
    voxel_zyx: Sequence[float], origin_zyx: Sequence[float], factors: Sequence[Sequence[int]]
) -> list[tuple[list[float], list[float]]]:
    """Return ``(scale, translation)`` ``(z, y, x)`` mm of each level (see the module).

    Examples
    --------
    >>> level_transforms((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), [(2, 1, 2)])
    [([1.0, 1.0, 1.0], [0.0, 0.0, 0.0]), ([2.0, 1.0, 2.0], [0.5, 0.0, 0.5])]
    """
    total = [1, 1, 1]
    out = []
    for step in [(1, 1, 1), *factors]:
        total = [t * int(f) for t, f in zip(total, step, strict=True)]
        scale = [float(v) * t for v, t in zip(voxel_zyx, total, strict=True)]
        translation = [
            float(o) + (t - 1) / 2 * float(v)
            for o, v, t in zip(origin_zyx, voxel_zyx, total, strict=True)
        ]
        out.append((scale, translation))
    return out


def multiscales(
    name: str, transforms: Sequence[tuple[list[float], list[float]]], *, channel: bool
) -> list[dict[str, Any]]:
    """Return the ``multiscales`` list of one image (with a leading ``c`` axis if `channel`)."""
    axes: list[dict[str, Any]] = [{"name": "c", "type": "channel"}] if channel else []
    axes += [{"name": a, "type": "space", "unit": "millimeter"} for a in ("z", "y", "x")]
    lead = [1.0] if channel else []
    lead0 = [0.0] if channel else []
    datasets = [
        {
            "path": str(level),
            "coordinateTransformations": [
                {"type": "scale", "scale": lead + scale},
                {"type": "translation", "translation": lead0 + translation},
            ],
        }
        for level, (scale, translation) in enumerate(transforms)
    ]
    return [{"name": name, "axes": axes, "datasets": datasets}]


def image_attributes(
    transforms: Sequence[tuple[list[float], list[float]]], samples: int
) -> dict[str, Any]:
    """Return the root's ``ome`` attributes: the colour image's multiscales and omero."""
    names = ("red", "green", "blue", "alpha")[:samples]
    colours = ("FF0000", "00FF00", "0000FF", "FFFFFF")
    window = {"min": 0, "max": 255, "start": 0, "end": 255}
    return {
        "version": NGFF_VERSION,
        "multiscales": multiscales("colour", transforms, channel=True),
        "omero": {
            "channels": [
                {"label": n, "color": c, "window": window, "active": True}
                for n, c in zip(names, colours, strict=False)
            ],
            "rdefs": {"model": "color"},
        },
    }


def label_attributes(
    name: str, transforms: Sequence[tuple[list[float], list[float]]], values: Sequence[LabelValue]
) -> dict[str, Any]:
    """Return a label image's ``ome`` attributes (``multiscales`` and ``image-label``)."""
    return {
        "version": NGFF_VERSION,
        "multiscales": multiscales(name, transforms, channel=False),
        "image-label": {
            "version": NGFF_VERSION,
            "colors": [{"label-value": v.value, "rgba": list(v.rgba)} for v in values],
            "properties": [{"label-value": v.value, **v.properties} for v in values],
            "source": {"image": "../../"},
        },
    }
