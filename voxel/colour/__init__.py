"""Colour and materials: encodings, surface colour, separation and halftones.

- :mod:`~shellvox.voxel.colour._srgb` the sRGB curve and CIELAB (the only place colours change
  encoding; the loaders in :mod:`pipeline` use it too);
- :mod:`~shellvox.voxel.colour._colour_at` colour of the nearest surface points;
  :mod:`~shellvox.voxel.colour._surface_colour` the same, compiled, per voxel;
- :mod:`~shellvox.voxel.colour._separation` colour to material proportions (the mixing model's
  solver in :mod:`~shellvox.voxel.colour._mixing`); :mod:`~shellvox.voxel.colour._blue_noise` the 3D
  threshold tile; :mod:`~shellvox.voxel.colour._materials` one material per voxel, with the compiled
  loops of :mod:`~shellvox.voxel.colour._material_kernels`;
- :mod:`~shellvox.voxel.colour._report` predicted printed colour at surface samples;
  :mod:`~shellvox.voxel.colour._proof` the soft proof: those predictions, kept and
  interpolated between samples.
"""

from __future__ import annotations

from shellvox.voxel.colour._blue_noise import DEFAULT_TILE, blue_noise_tile
from shellvox.voxel.colour._calibration import (
    Patch,
    chart_patches,
    cross_validate,
    delta_e_of_readings,
    fit_optics,
    predict,
)
from shellvox.voxel.colour._colour_at import ColourAt, nearest_colour
from shellvox.voxel.colour._depth_effect import depth_effect
from shellvox.voxel.colour._inversion import DeepColour, invert, project_to_simplex
from shellvox.voxel.colour._kubelka_munk import (
    K1_DEFAULT,
    K2_DEFAULT,
    WAVELENGTHS_NM,
    lab_d50_to_srgb8,
    layer,
    mix,
    observer,
    over,
    r_infinity,
    reflectance_to_lab,
    saunderson,
    srgb_to_lab_d50,
    stack,
)
from shellvox.voxel.colour._materials import HALFTONES, Halftone, MaterialPlan, materials_for_slab
from shellvox.voxel.colour._mixing import mix_proportions
from shellvox.voxel.colour._model_report import REACH_LIMITS_MM, ModelReport, lateral_reach, summary
from shellvox.voxel.colour._model_separation import model_separation
from shellvox.voxel.colour._optics import (
    Optics,
    assumed_optics,
    body_reflectance,
    display_reflectance,
)
from shellvox.voxel.colour._proof import (
    IN_GAMUT_DE,
    PROOF_MAX_SAMPLES,
    PROOF_SAMPLES_PER_MM2,
    SoftProof,
)
from shellvox.voxel.colour._report import (
    SurfaceSamples,
    colour_regions,
    sample_surface,
    statistics,
    tangent_basis,
)
from shellvox.voxel.colour._separation import (
    Separation,
    SeparationError,
    cmyk_to_proportions,
    icc_separation,
    mixing_separation,
)
from shellvox.voxel.colour._settling import LayerModel, Settling, settling_depth
from shellvox.voxel.colour._srgb import (
    DECODE_LUT,
    codes_to_linear,
    decode_uint8,
    encode_uint8,
    lab_to_srgb8,
    linear_to_lab,
    linear_to_srgb,
    srgb8_to_lab,
    srgb_to_lab,
    srgb_to_linear,
)
from shellvox.voxel.colour._surface_colour import (
    CONSTANT,
    FACE,
    FILTER_CODES,
    TEXTURE,
    VERTEX,
    WRAP_CODES,
    SurfaceColour,
    voxel_colours,
)

__all__ = [
    "CONSTANT",
    "DECODE_LUT",
    "DEFAULT_TILE",
    "FACE",
    "FILTER_CODES",
    "HALFTONES",
    "IN_GAMUT_DE",
    "K1_DEFAULT",
    "K2_DEFAULT",
    "PROOF_MAX_SAMPLES",
    "PROOF_SAMPLES_PER_MM2",
    "REACH_LIMITS_MM",
    "TEXTURE",
    "VERTEX",
    "WAVELENGTHS_NM",
    "WRAP_CODES",
    "ColourAt",
    "DeepColour",
    "Halftone",
    "LayerModel",
    "MaterialPlan",
    "ModelReport",
    "Optics",
    "Patch",
    "Separation",
    "SeparationError",
    "Settling",
    "SoftProof",
    "SurfaceColour",
    "SurfaceSamples",
    "assumed_optics",
    "blue_noise_tile",
    "body_reflectance",
    "chart_patches",
    "cmyk_to_proportions",
    "codes_to_linear",
    "colour_regions",
    "cross_validate",
    "decode_uint8",
    "delta_e_of_readings",
    "depth_effect",
    "display_reflectance",
    "encode_uint8",
    "fit_optics",
    "icc_separation",
    "invert",
    "lab_d50_to_srgb8",
    "lab_to_srgb8",
    "lateral_reach",
    "layer",
    "linear_to_lab",
    "linear_to_srgb",
    "materials_for_slab",
    "mix",
    "mix_proportions",
    "mixing_separation",
    "model_separation",
    "nearest_colour",
    "observer",
    "over",
    "predict",
    "project_to_simplex",
    "r_infinity",
    "reflectance_to_lab",
    "sample_surface",
    "saunderson",
    "settling_depth",
    "srgb8_to_lab",
    "srgb_to_lab",
    "srgb_to_lab_d50",
    "srgb_to_linear",
    "stack",
    "statistics",
    "summary",
    "tangent_basis",
    "voxel_colours",
]
