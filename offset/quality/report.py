"""JSON-ready quality report of offset shells and of the two baselines."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import trimesh

from shellvox.offset._validate import FloatArray, IntArray, check_mesh, check_thickness
from shellvox.offset.crossing.intersections import count_self_intersections
from shellvox.offset.quality.baselines import slicer_thickness, vertex_normal_offset
from shellvox.offset.quality.measures import equidistance, mesh_checks, nested_in, percentiles
from shellvox.offset.shells import Shell


def shell_report(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    thickness: npt.ArrayLike,
    shells: Sequence[Shell],
    *,
    baselines: bool = True,
    layer_height_mm: float = 0.027,
    n_samples: int = 20_000,
    seed: int = 0,
    checks: Sequence[dict[str, Any]] | None = None,
    crossing_free: bool = False,
) -> dict[str, Any]:
    """Measure every shell, and optionally the baselines, against the ideal offset.

    Parameters
    ----------
    vertices : (V, 3) array_like of float, mm
    faces : (F, 3) array_like of int
        The original closed, outward-oriented surface.
    thickness : (K, F) or (K,) array_like of float, mm
        The thickness the shells were made with.
    shells : sequence of Shell
        ``K`` shells from :func:`shellvox.offset.offset_shells`, outside in.
    baselines : bool, optional
        Also measure the vertex-normal offset and the slicer's 2D contour offset.
    layer_height_mm : float, optional
        Slice spacing of the slicer baseline, mm.
    n_samples : int, optional
        Points sampled on each shell (and on the surface, for the slicer baseline).
    seed : int, optional
        Sampling seed.
    checks : sequence of dict, optional
        :func:`shellvox.offset.quality.measures.mesh_checks` of each shell when already measured (on
        its file read back); default: measured here.
    crossing_free : bool, optional
        The shells, exactly as given and all together, were already tested with no
        crossing pair: a shell's nesting in the one before it needs only the winding test
        (layer 1's in the surface is tested here as always).

    Returns
    -------
    dict
        Plain JSON types. ``input_self_intersections`` counts crossing face pairs of the
        input (a self-intersecting input bounds no well-defined solid).
        ``layers[k]["shell"]`` holds :func:`shellvox.offset.quality.measures.mesh_checks`
        keys, ``nested`` (inside the previous shell, or the surface for layer 1) and
        ``equidistance`` (:func:`shellvox.offset.quality.measures.equidistance`);
        ``layers[k]["baselines"]`` the same for ``vertex_normal`` and the thickness error of
        ``slicer_contour``.
    """
    v, f = check_mesh(vertices, faces)
    t = check_thickness(thickness, f.shape[0])
    if len(shells) != t.shape[0]:
        raise ValueError(f"shells must hold one shell per layer ({t.shape[0]}), got {len(shells)}")
    if checks is not None and len(checks) != len(shells):
        raise ValueError(f"checks must hold one entry per shell ({len(shells)}), got {len(checks)}")
    if not layer_height_mm > 0:
        raise ValueError(f"layer_height_mm must be > 0, got {layer_height_mm!r}")
    depth = np.cumsum(t, axis=0)
    original = trimesh.Trimesh(v, f, process=False)
    rng = np.random.default_rng(seed)
    naive = vertex_normal_offset(v, f, depth) if baselines else []
    layers: list[dict[str, Any]] = []
    previous: tuple[FloatArray, IntArray] = (v, f)
    previous_naive: tuple[FloatArray, IntArray] = (v, f)
    for k, shell in enumerate(shells):
        entry: dict[str, Any] = {
            "layer": shell.layer,
            "depth_mm": {"min": float(depth[k].min()), "max": float(depth[k].max())},
            "shell": _measure(
                original,
                depth[k],
                (shell.vertices, shell.faces),
                previous,
                n_samples,
                rng,
                checks=None if checks is None else checks[k],
                crossing_free=crossing_free and k > 0,
            ),
        }
        previous = (shell.vertices, shell.faces)
        if baselines:
            entry["baselines"] = {
                "vertex_normal": _measure(
                    original, depth[k], naive[k], previous_naive, n_samples, rng
                ),
                "slicer_contour": _slicer(original, depth[k], layer_height_mm, n_samples, rng),
            }
            previous_naive = naive[k]
        layers.append(entry)
    return {
        "n_faces": int(f.shape[0]),
        "n_layers": int(t.shape[0]),
        "input_self_intersections": count_self_intersections(v, f),
        "layers": layers,
    }


def _measure(
    original: trimesh.Trimesh,
    depth: FloatArray,
    mesh: tuple[FloatArray, IntArray],
    previous: tuple[FloatArray, IntArray],
    n_samples: int,
    rng: np.random.Generator,
    *,
    checks: dict[str, Any] | None = None,
    crossing_free: bool = False,
) -> dict[str, Any]:
    """Return mesh checks (`checks` when given), nesting and equidistance of one shell.

    `crossing_free`: `mesh` and `previous` were tested together with no crossing pair.
    """
    result = dict(checks) if checks is not None else mesh_checks(*mesh)
    closed = result["closed"]
    result["nested"] = nested_in(mesh, previous, crossing_free=crossing_free) if closed else False
    if mesh[1].shape[0] == 0:
        result["equidistance"] = None
        return result
    tm = trimesh.Trimesh(mesh[0], mesh[1], process=False)
    points, _ = trimesh.sample.sample_surface(tm, n_samples, seed=int(rng.integers(2**31)))
    result["equidistance"] = equidistance(original, depth, np.asarray(points, dtype=np.float64))
    return result


def _slicer(
    original: trimesh.Trimesh,
    depth: FloatArray,
    layer_height_mm: float,
    n_samples: int,
    rng: np.random.Generator,
) -> dict[str, Any]:
    """Return the thickness error of the slicer's contour offset at its mean width."""
    points, face = trimesh.sample.sample_surface(original, n_samples, seed=int(rng.integers(2**31)))
    width = float(np.average(depth, weights=original.area_faces))
    measured = slicer_thickness(
        original,
        width,
        np.asarray(points, dtype=np.float64),
        np.asarray(original.face_normals[face], dtype=np.float64),
        layer_height_mm=layer_height_mm,
    )
    err_pct = 100.0 * np.abs(measured - depth[face]) / depth[face]
    return {"width_mm": width, "n_samples": len(points), "error_pct": percentiles(err_pct)}
