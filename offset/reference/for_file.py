"""A shell made ready for a file: cleaned, then its coplanar pairs jittered.

A shell (:func:`shellvox.offset.offset_shells`) is exact in float64 but carries clusters of
vertices and slivers far below a micrometre; written in float32 (trimesh's PLY export)
they become zero-area faces and coincident vertices. Its flat regions are also exactly
coplanar, which a triangle test without a coplanarity tolerance (MeshLab's) reads as
crossings at random. :func:`shell_for_file` cleans the shell
(:func:`shellvox.offset.reference.clean.clean_offset_shell`) and moves the vertices of coplanar
triangle pairs by a tiny random amount (:func:`shellvox.offset.reference.jitter.jitter_vertices`,
1e-8 of the extent, seed 0: reproducible). The voxels never use these shells;
:mod:`shellvox.output._shells` writes them.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, NamedTuple

from shellvox.offset.reference.clean import clean_offset_shell
from shellvox.offset.reference.jitter import jitter_vertices
from shellvox.offset.shells import Shell


class ShellForFile(NamedTuple):
    """A shell ready for its file, and what was done to it.

    Attributes
    ----------
    shell : Shell
        The cleaned faces and the jittered vertices; the same layer and depths.
    cleaning : dict
        ``tol_mm``, ``collapsed_vertices``, ``flipped_edges``, ``max_move_mm``,
        ``short_edges_left``, ``thin_faces_left`` (see
        :class:`shellvox.offset.reference.clean.CleanedMesh`), then ``jitter_mm``,
        ``jitter_moved_vertices``, ``jitter_kept_vertices`` and ``coplanar_pairs_left`` (see
        :class:`shellvox.offset.reference.jitter.JitteredMesh`); a vertex moved at most
        ``max_move_mm + jitter_mm`` in all.
    """

    shell: Shell
    cleaning: dict[str, Any]


def shell_for_file(shell: Shell) -> ShellForFile:
    """Return `shell` cleaned and jittered, with the record of both steps."""
    cleaned_shell, cleaned = clean_offset_shell(shell)
    jittered = jitter_vertices(cleaned_shell.vertices, cleaned_shell.faces)
    return ShellForFile(
        replace(cleaned_shell, vertices=jittered.vertices),
        {
            "tol_mm": cleaned.tol_mm,
            "collapsed_vertices": cleaned.n_collapsed,
            "flipped_edges": cleaned.n_flipped,
            "max_move_mm": cleaned.max_move_mm,
            "short_edges_left": cleaned.short_edges,
            "thin_faces_left": cleaned.thin_faces,
            "jitter_mm": jittered.amplitude_mm,
            "jitter_moved_vertices": jittered.n_moved,
            "jitter_kept_vertices": jittered.n_kept,
            "coplanar_pairs_left": jittered.coplanar_pairs,
        },
    )
