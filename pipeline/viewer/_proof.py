"""The soft proof on the 3D view's faces: predicted printed colour and its error per face.

A build with materials and a colour report keeps its soft proof as ``proof.ply``
(:func:`~shellvox.output.read_proof_ply`): the printed colour predicted from the build's
voxels, and its CIEDE2000 errors, at surface samples about 0.3 mm apart. The page's
faces take the values of the proof interpolated at their centres, on their outward side
(:meth:`~shellvox.voxel.colour.SoftProof.at`): nothing is recomputed from the voxels.

:class:`FaceProof` is what ``/api/proof`` sends, face for face with ``/api/surface``
(:meth:`FaceProof.to_bytes`). The page draws the error on the soft-proof picture's scale
(``preview/soft_proof.png``, :mod:`shellvox.voxel.io`), which ``/api/build`` sends as
:func:`de_scale` says: the page has no colours of its own for it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from shellvox.voxel.colour import IN_GAMUT_DE, SoftProof
from shellvox.voxel.io import DE_RGB, DE_STEPS, HATCH_PERIOD, HATCH_RGB, NO_PREDICTION_RGB


@dataclass(frozen=True)
class FaceProof:
    """The soft proof at each face of the page's surface.

    Parameters
    ----------
    predicted_srgb : (F, 3) uint8
        Predicted printed colour (sRGB codes, clipped to sRGB); grey ``(160, 160, 160)``
        where the proof has no prediction near the face.
    total_de : (F,) float32
        CIEDE2000 of the prediction against the model's colour (NaN where none).
    gamut_de : (F,) float32
        CIEDE2000 of the separation's aim against the model's colour: above
        :data:`~shellvox.voxel.colour.IN_GAMUT_DE` the target is out of the materials'
        gamut (NaN where none).
    optics : str
        ``"assumed"`` (the profile's default optics) or ``"measured"`` (a calibrated
        profile): what the prediction rests on.
    """

    predicted_srgb: NDArray[np.uint8]
    total_de: NDArray[np.float32]
    gamut_de: NDArray[np.float32]
    optics: str

    def to_bytes(self) -> bytes:
        """Return ``total_de``, ``gamut_de`` and ``predicted_srgb`` back to back.

        ``F`` little-endian float32 (NaN where none), ``F`` more, then ``3 F`` uint8:
        ``11 F`` bytes, each array at an offset a typed array can start at.
        """
        return b"".join(
            (
                np.ascontiguousarray(self.total_de, "<f4").tobytes(),
                np.ascontiguousarray(self.gamut_de, "<f4").tobytes(),
                np.ascontiguousarray(self.predicted_srgb, np.uint8).tobytes(),
            )
        )

    def headers(self) -> dict[str, str]:
        """HTTP headers describing :meth:`to_bytes`."""
        return {
            "X-Faces": str(len(self.total_de)),
            "X-Optics": self.optics,
            "X-In-Gamut-DE": repr(float(IN_GAMUT_DE)),
        }


def face_proof(proof: SoftProof, triangles_mm: NDArray[np.floating]) -> FaceProof:
    """Return the proof at the centres of `triangles_mm`, on each face's outward side.

    Parameters
    ----------
    proof : SoftProof
        The build's soft proof.
    triangles_mm : (F, 3, 3) float, mm
        Corners ``(x, y, z)`` of each face, in outward-facing order.

    Returns
    -------
    FaceProof
        A face whose normal is undefined (no area) or that no sample faces has no
        prediction.

    Examples
    --------
    A proof of one sample at the origin, facing +z, and a face beside it:

    >>> import numpy as np
    >>> from shellvox.voxel.colour import SoftProof
    >>> lab, one = np.array([[50.0, 0.0, 0.0]]), np.ones(1)
    >>> proof = SoftProof(
    ...     points_mm=np.zeros((1, 3)),
    ...     normals=np.array([[0.0, 0.0, 1.0]]),
    ...     target_lab=lab,
    ...     aim_lab=lab,
    ...     predicted_lab=lab,
    ...     total_de=one,
    ...     gamut_de=0 * one,
    ...     reproduction_de=one,
    ...     spacing_mm=0.1,
    ...     white_xy=np.array([0.3457, 0.3585]),
    ...     optics="assumed",
    ... )
    >>> face = np.array([[[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]]])
    >>> out = face_proof(proof, face)
    >>> out.predicted_srgb.shape, float(out.total_de[0]), out.optics
    ((1, 3), 1.0, 'assumed')
    """
    triangles = np.asarray(triangles_mm, np.float64)
    if triangles.ndim != 3 or triangles.shape[1:] != (3, 3):
        raise ValueError(f"triangles_mm must be (F, 3, 3), got {triangles.shape}")
    centres = triangles.mean(axis=1)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    at = proof.at(centres, normals)  # normalises the normals; zero ones face nothing
    return FaceProof(
        predicted_srgb=at.srgb("predicted"),
        total_de=at.total_de.astype(np.float32),
        gamut_de=at.gamut_de.astype(np.float32),
        optics=proof.optics,
    )


def de_scale() -> dict[str, Any]:
    """Return the ΔE mode's scale, the soft-proof picture's, as ``/api/build`` sends it.

    Returns
    -------
    dict
        JSON-ready: ``steps``, the CIEDE2000 steps of :data:`~shellvox.voxel.io.DE_STEPS`
        in order, each ``{"low": float, "high": float or None (open), "label": str,
        "srgb": [r, g, b]}`` (:data:`~shellvox.voxel.io.DE_RGB`, sRGB codes 0-255), a
        face's step the last whose ``low`` is at most its error (as
        :func:`~shellvox.voxel.io.de_colours`); ``no_prediction_srgb``
        (:data:`~shellvox.voxel.io.NO_PREDICTION_RGB`); ``hatch_srgb``
        (:data:`~shellvox.voxel.io.HATCH_RGB`) and ``hatch_period_px``: out-of-gamut faces
        are hatched as the picture is, the pixels of screen row ``r`` and column ``c``
        with ``(r + c) % hatch_period_px == 0``.

    Examples
    --------
    >>> scale = de_scale()
    >>> [step["label"] for step in scale["steps"]]
    ['0-1', '1-2', '2-3', '3-5', '5-10', '>= 10']
    >>> scale["steps"][-1]["high"], scale["steps"][0]["srgb"]
    (None, [255, 255, 178])
    """
    highs: list[float | None] = [*DE_STEPS[1:], None]
    steps = [
        {
            "low": float(low),
            "high": None if high is None else float(high),
            "label": f">= {low:g}" if high is None else f"{low:g}-{high:g}",
            "srgb": [int(c) for c in rgb],
        }
        for low, high, rgb in zip(DE_STEPS, highs, DE_RGB, strict=True)
    ]
    return {
        "steps": steps,
        "no_prediction_srgb": [int(c) for c in NO_PREDICTION_RGB],
        "hatch_srgb": [int(c) for c in HATCH_RGB],
        "hatch_period_px": int(HATCH_PERIOD),
    }
