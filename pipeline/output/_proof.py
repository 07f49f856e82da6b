"""``proof.ply``: a build's soft proof as a coloured point cloud.

One ``vertex`` element, binary little-endian PLY 1.0, a row per surface sample of
:class:`shellvox.voxel.colour.SoftProof`: ``double x, y, z`` (mm), ``float nx, ny, nz``
(the outward normal), ``uchar red, green, blue`` (the *predicted* colour in sRGB, so
MeshLab, CloudCompare or trimesh show the print as predicted), then ``float`` CIELAB
``target_L, target_a, target_b``, ``aim_*`` and ``predicted_*`` (NaN where nothing was
predicted) and the CIEDE2000 errors ``total_de``, ``gamut_de``, ``reproduction_de``. The
header's comments give the mean sample spacing, the CIELAB white and whether the optics
are assumed or measured; the manifest's ``proof`` section says how the values were made.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from shellvox.atomic import atomic_path
from shellvox.voxel.colour import SoftProof

#: The file's name in a build folder.
PROOF_FILE = "proof.ply"

_LAB = ("target", "aim", "predicted")
_ERRORS = ("total_de", "gamut_de", "reproduction_de")
_ROW = np.dtype(
    [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    + [(name, "<f4") for name in ("nx", "ny", "nz")]
    + [(name, "u1") for name in ("red", "green", "blue")]
    + [(f"{which}_{c}", "<f4") for which in _LAB for c in "Lab"]
    + [(name, "<f4") for name in _ERRORS]
)
_NAMES: tuple[str, ...] = tuple(_ROW.fields or ())
_TYPES = {"<f8": "double", "<f4": "float", "|u1": "uchar"}


def write_proof_ply(path: str | Path, proof: SoftProof) -> None:
    """Write `proof` to `path` atomically (see the module)."""
    rows = np.empty(len(proof), _ROW)
    for axis, name in enumerate("xyz"):
        rows[name] = proof.points_mm[:, axis]
        rows[f"n{name}"] = proof.normals[:, axis]
    shown = proof.srgb("predicted")
    for channel, name in enumerate(("red", "green", "blue")):
        rows[name] = shown[:, channel]
    for which in _LAB:
        lab = getattr(proof, f"{which}_lab")
        for channel, c in enumerate("Lab"):
            rows[f"{which}_{c}"] = lab[:, channel]
    for name in _ERRORS:
        rows[name] = getattr(proof, name)
    white = ",".join(repr(float(v)) for v in proof.white_xy)
    header = [
        "ply",
        "format binary_little_endian 1.0",
        "comment shellvox soft proof: predicted printed colour at surface samples",
        f"comment spacing_mm {proof.spacing_mm!r}",
        f"comment white_xy {white}",
        f"comment optics {proof.optics}",
        f"element vertex {len(rows)}",
        *(f"property {_TYPES[_ROW[n].str]} {n}" for n in _NAMES),
        "end_header",
    ]
    with atomic_path(Path(path)) as temporary, open(temporary, "wb") as stream:
        stream.write(("\n".join(header) + "\n").encode("ascii"))
        stream.write(rows.tobytes())


def read_proof_ply(path: str | Path) -> SoftProof:
    """Read a ``proof.ply`` written by :func:`write_proof_ply`.

    Raises
    ------
    ValueError
        The file is not such a proof (its header names the first difference).
    """
    data = Path(path).read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise ValueError("is not a PLY file")
    lines = data[:end].decode("ascii", "replace").splitlines()
    comments = dict(
        line.split(" ", 2)[1:]
        for line in lines
        if line.startswith("comment ") and line.count(" ") >= 2
    )
    properties = [line.split()[-1] for line in lines if line.startswith("property ")]
    counts = [line.split()[-1] for line in lines if line.startswith("element vertex ")]
    if properties != list(_NAMES) or len(counts) != 1:
        raise ValueError("is not a shellvox proof.ply (its properties differ)")
    missing = [key for key in ("spacing_mm", "white_xy", "optics") if key not in comments]
    if missing:
        raise ValueError(f"has no {', '.join(missing)} comment in its header")
    count = int(counts[0])
    body = data[end + len(b"end_header\n") :]
    if len(body) != count * _ROW.itemsize:
        raise ValueError(f"holds {len(body)} bytes of samples, {count * _ROW.itemsize} expected")
    rows = np.frombuffer(body, _ROW, count)
    try:
        spacing = float(comments["spacing_mm"])
        white = np.array([float(v) for v in comments["white_xy"].split(",")])
    except ValueError:
        raise ValueError("has a malformed spacing_mm or white_xy comment") from None
    if not (spacing > 0 and white.shape == (2,)):
        raise ValueError("has a malformed spacing_mm or white_xy comment")

    def columns(*names: str) -> np.ndarray:
        return np.stack([rows[n].astype(np.float64) for n in names], axis=1)

    return SoftProof(
        points_mm=columns("x", "y", "z"),
        normals=columns("nx", "ny", "nz"),
        target_lab=columns("target_L", "target_a", "target_b"),
        aim_lab=columns("aim_L", "aim_a", "aim_b"),
        predicted_lab=columns("predicted_L", "predicted_a", "predicted_b"),
        total_de=rows["total_de"].astype(np.float64),
        gamut_de=rows["gamut_de"].astype(np.float64),
        reproduction_de=rows["reproduction_de"].astype(np.float64),
        spacing_mm=spacing,
        white_xy=white,
        optics=comments["optics"],
    )
