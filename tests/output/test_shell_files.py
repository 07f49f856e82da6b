"""Shell files: float64 PLY, cleaned of degenerate faces, valid as trimesh and MeshLab read them.

Truths: the real readers (trimesh, pymeshlab when installed), the crossing test of
shellvox.offset.crossing.intersections on the mesh read back and merged, analytic volumes, the
topology of the meshes built here by hand, and exact rational arithmetic (fractions) for the
triangles MeshLab misjudges.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import trimesh
from meshlab_process import needs_meshlab

from shellvox.cli import main
from shellvox.errors import ShellvoxWarning
from shellvox.offset.adjacency import edge_adjacency
from shellvox.offset.reference.clean import clean_degenerate, clean_shell, folded_faces
from shellvox.offset.reference.for_file import shell_for_file
from shellvox.offset.reference.jitter import JITTER_FRACTION
from shellvox.offset.reference.robust import ShellDefectWarning
from shellvox.offset.shells import Shell
from shellvox.output import read_ply, save_shells, write_ply, write_shell
from shellvox.testing import HAVE_PYMESHLAB, meshlab_checks, ply_header, trimesh_checks


def _euler(faces):
    pairs = np.sort(np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges = np.unique(pairs, axis=0)
    return len(np.unique(faces)) - len(edges) + len(faces)


def test_write_ply_keeps_every_float64_bit(tmp_path):
    rng = np.random.default_rng(1)
    vertices = rng.normal(size=(50, 3)) * 10 + 1e-9  # not representable in float32
    faces = rng.integers(0, 50, size=(80, 3))
    write_ply(tmp_path / "m.ply", vertices, faces, comment="test")
    assert {"property double x", "property double y", "property double z"} <= set(
        ply_header(tmp_path / "m.ply")
    )
    mesh = trimesh.load(tmp_path / "m.ply", process=False, force="mesh")
    assert np.array_equal(np.asarray(mesh.vertices), vertices)
    assert np.array_equal(np.asarray(mesh.faces), faces)
    v, f = read_ply(tmp_path / "m.ply")
    assert np.array_equal(v, vertices) and np.array_equal(f, faces)


def _split_edge_near_end(mesh: trimesh.Trimesh, gap: float):
    """Split one edge of a closed mesh at ``gap`` (relative) from one end: a short edge."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    a, b = f[0, 0], f[0, 1]
    m = len(v)
    v = np.vstack([v, v[a] + gap * (v[b] - v[a])])
    out = []
    for tri in f:
        for j in range(3):
            x, y, z = tri[j], tri[(j + 1) % 3], tri[(j + 2) % 3]
            if {x, y} == {a, b}:
                out += [[x, m, z], [m, y, z]]
                break
        else:
            out.append(list(tri))
    return v, np.asarray(out, dtype=np.int64)


def test_a_short_edge_is_collapsed_back_to_the_solid_it_came_from():
    ico = trimesh.creation.icosahedron()
    v, f = _split_edge_near_end(ico, 1e-9)
    assert len(f) == 22
    cleaned = clean_degenerate(v, f, tol=1e-6)
    assert len(cleaned.faces) == 20
    assert cleaned.n_collapsed == 1
    edge_adjacency(cleaned.faces)  # closed, manifold, consistently oriented
    assert _euler(cleaned.faces) == 2
    mesh = trimesh.Trimesh(cleaned.vertices, cleaned.faces, process=False)
    assert mesh.volume == pytest.approx(ico.volume, rel=1e-8)
    assert cleaned.max_move_mm <= 1e-9


def _prism_with_a_sliver(eps: float):
    """A prism over the quad a, p, b, c with p within `eps` of segment ab; caps hold (a, b, p)."""
    base = np.array([[0, 0], [1, -eps], [2, 0], [1, 1]], dtype=np.float64)  # a, p, b, c
    v = np.vstack([np.c_[base, np.zeros(4)], np.c_[base, np.ones(4)]])
    a, p, b, c = 0, 1, 2, 3
    bottom = [[a, p, b], [a, b, c]]  # seen from below: outward is -z
    top = [[a + 4, b + 4, p + 4], [a + 4, c + 4, b + 4]]
    ring = [a, p, b, c]
    sides = []
    for i in range(4):
        s, t = ring[i], ring[(i + 1) % 4]
        sides += [[s, t + 4, t], [s, s + 4, t + 4]]
    f = np.asarray(bottom + top + sides, dtype=np.int64)
    mesh = trimesh.Trimesh(v, f, process=False)
    if mesh.volume < 0:
        f = f[:, ::-1]
    return v, f


def test_a_sliver_is_flipped_away_without_changing_the_solid():
    eps = 1e-9
    v, f = _prism_with_a_sliver(eps)
    cleaned = clean_degenerate(v, f, tol=1e-4)
    assert cleaned.n_flipped == 2  # one per cap
    assert cleaned.thin_faces == 0 and cleaned.short_edges == 0
    edge_adjacency(cleaned.faces)
    # Quad (0,0) (1,-eps) (2,0) (1,1): area 1 + eps, height 1.
    volume = trimesh.Trimesh(cleaned.vertices, cleaned.faces, process=False).volume
    assert volume == pytest.approx(1.0 + eps, rel=1e-12)


def test_clean_shell_never_adds_crossings():
    # Two boxes overlapping as one mesh cross each other; cleaning must not hide or add.
    a = trimesh.creation.box((2, 2, 2))
    b = trimesh.creation.box((2, 2, 2))
    b.apply_translation((1, 1, 1))
    v = np.vstack([a.vertices, b.vertices])
    f = np.vstack([a.faces, b.faces + len(a.vertices)])
    cleaned = clean_shell(v, f, tol=1e-3)
    assert np.array_equal(cleaned.faces, f)


def test_a_crossing_shell_file_is_reported_in_one_warning(tmp_path):
    a = trimesh.creation.box((2, 2, 2))
    b = trimesh.creation.box((2, 2, 2))
    b.apply_translation((1, 1, 1))
    shell = Shell(
        vertices=np.vstack([a.vertices, b.vertices]),
        faces=np.vstack([a.faces, b.faces + len(a.vertices)]).astype(np.int64),
        layer=1,
        depth_mm=np.full(12, 0.5),
    )
    with pytest.warns(ShellvoxWarning, match=r"shell_1\.ply: .*crossing triangle pairs"):
        written = save_shells(tmp_path, [shell])
    assert written[0].checks["self_intersections"] > 0


@pytest.fixture(scope="module")
def icosphere_out(tmp_path_factory):
    """The issue's case through the CLI: icosphere (5,120 faces, r 10 mm), 0.5 + 0.5 mm."""
    tmp_path = tmp_path_factory.mktemp("ico")
    ico = trimesh.creation.icosphere(subdivisions=4, radius=10.0)
    ico.export(tmp_path / "ico.obj")
    out = tmp_path / "out"
    assert (
        main(
            [
                "shells",
                str(tmp_path / "ico.obj"),
                "-o",
                str(out),
                "--thickness",
                "0.5,0.5",
                "--no-baselines",
                "--method",
                "robust",
            ]
        )
        == 0
    )
    return out


def test_icosphere_shell_files_are_valid_as_trimesh_reads_them(icosphere_out):
    out = icosphere_out
    report = json.loads((out / "report.json").read_text())
    for layer in (1, 2):
        path = out / f"shell_{layer}.ply"
        assert "property double x" in ply_header(path)
        seen = trimesh_checks(path)
        assert seen["vertex_dtype"] == "float64"
        assert seen["merged_vertices"] == 0
        assert seen["closed"] and seen["oriented"]
        assert seen["zero_area_faces"] == 0
        assert seen["self_intersections"] == 0
        assert seen["folded_edges"] == 0
        # The report describes this file.
        entry = report["layers"][layer - 1]
        assert entry["shell"]["n_faces"] == seen["n_faces"]
        assert entry["shell"]["closed"] and entry["shell"]["nested"]
        assert entry["shell"]["zero_area_faces"] == 0
        assert entry["shell"]["self_intersections"] == 0
        assert entry["file"]["path"] == path.name
        assert entry["file"]["bytes"] == path.stat().st_size
        # Cleaning moved the surface by far less than a printer voxel (>= 14 um).
        cleaning = entry["file"]["cleaning"]
        assert cleaning["max_move_mm"] < 4 * cleaning["tol_mm"]
        assert 0 < cleaning["jitter_mm"] <= JITTER_FRACTION * 20.0
        mesh = trimesh.load(path, process=False, force="mesh")
        radius = np.linalg.norm(mesh.vertices, axis=1)
        # Inside the sphere of radius 10 - 0.5 k, outside the inscribed one of the polytope.
        assert radius.max() <= 10.0 - 0.5 * layer + cleaning["jitter_mm"]


@needs_meshlab
def test_icosphere_shell_files_are_valid_as_meshlab_reads_them(icosphere_out):
    out = icosphere_out
    for layer in (1, 2):
        seen = meshlab_checks(out / f"shell_{layer}.ply")
        assert seen["two_manifold"]
        assert seen["boundary_edges"] == 0
        assert seen["non_manifold_edges"] == 0 and seen["non_manifold_vertices"] == 0
        assert seen["zero_area_faces"] == 0
        assert seen["self_intersecting_faces"] == 0
        assert seen["n_faces"] == trimesh_checks(out / f"shell_{layer}.ply")["n_faces"]


def test_a_shell_defect_warning_reaches_the_user_as_one_line(tmp_path, capsys, monkeypatch):
    from shellvox.offset import METHODS

    robust = METHODS["robust"]

    def defective(*args, **kwargs):
        warnings.warn(
            "robust shell of layer 1: 2 crossing triangle pairs remain",
            ShellDefectWarning,
            stacklevel=2,
        )
        return robust.make(*args, **kwargs)

    monkeypatch.setitem(METHODS, "robust", robust._replace(make=defective))
    trimesh.creation.box((10.0, 8.0, 6.0)).export(tmp_path / "box.stl")
    assert (
        main(
            [
                "shells",
                str(tmp_path / "box.stl"),
                "-o",
                str(tmp_path / "o"),
                "--thickness",
                "0.5",
                "--no-baselines",
                "--method",
                "robust",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["shellvox: warning: robust shell of layer 1: 2 crossing triangle pairs remain"]


CASES = {
    "bunny": ("bunny/bunny.obj", 50.0),
    "spot": ("spot/spot_triangulated.obj", 100.0),
}


@pytest.mark.slow
@pytest.mark.parametrize(  # on the worker that computes these shells for the offset tests
    "name", [pytest.param(n, marks=pytest.mark.xdist_group(f"shells_{n}")) for n in CASES]
)
def test_real_mesh_shell_files_are_valid_outside_shellvox(real_mesh_shells, tmp_path, name):
    relative, size_mm = CASES[name]
    # At 0.5 and 1.5 mm; computed once per run (shared with test_offset_real_meshes).
    _, shells, caught = real_mesh_shells(relative, size_mm)
    assert [str(w.message) for w in caught] == []
    ready = [shell_for_file(shell) for shell in shells]
    cleaning = [r.cleaning for r in ready]
    # a ShellvoxWarning (defective file) fails
    written = save_shells(tmp_path, [r.shell for r in ready], cleaning=cleaning)
    for w in written:
        assert "property double x" in ply_header(w.path)
        seen = trimesh_checks(w.path)
        assert seen["merged_vertices"] == 0
        assert seen["closed"] and seen["oriented"]
        assert seen["zero_area_faces"] == 0
        assert seen["self_intersections"] == 0
        assert seen["folded_edges"] == 0
        assert w.checks["n_faces"] == seen["n_faces"]
        # Moved by less than a micrometre in all (1e-3 of the 1 um voxel of the finest
        # printer profile is far below what matters; this bounds the depth error).
        assert w.cleaning["max_move_mm"] + w.cleaning["jitter_mm"] < 1e-2
        # The smallest angle the checks state is the one trimesh reads in the file.
        angles = np.degrees(trimesh.load(w.path, process=False).face_angles)
        assert w.checks["min_angle_deg"] == pytest.approx(angles.min(), abs=1e-5)
        if HAVE_PYMESHLAB:
            ml = meshlab_checks(w.path)
            assert ml["two_manifold"] and ml["boundary_edges"] == 0
            assert ml["zero_area_faces"] == 0
            # Before the jitter, 230 to 500 faces of each, all beside a coplanar face.
            assert ml["self_intersecting_faces"] == 0


def test_write_shell_of_a_collapsed_layer_writes_an_empty_file(tmp_path):
    empty = Shell(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), 2, np.full(4, 1.0))
    written = write_shell(tmp_path / "s.ply", empty)
    assert written.shell.faces.shape == (0, 3)
    assert "element face 0" in ply_header(tmp_path / "s.ply")


def test_folded_faces_finds_faces_back_to_back():
    ico = trimesh.creation.icosahedron()
    assert folded_faces(ico.vertices, np.asarray(ico.faces, np.int64)).size == 0
    # A closed, flat double layer: two triangles, one the other turned over.
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 1]])
    np.testing.assert_array_equal(folded_faces(v, f), [0, 1])


def test_a_tested_shell_read_back_as_given_is_not_tested_again(tmp_path, monkeypatch):
    # The field method's guard tests all shells together; a file that reads back as given
    # takes that count, one that does not (here: a vertex moved on the way) is tested.
    from shellvox.offset.quality import measures as quality
    from shellvox.output import _shells

    box = trimesh.creation.box((4.0, 4.0, 4.0))
    shell = Shell(box.vertices, np.asarray(box.faces, np.int64), 1, np.full(12, 0.5))
    measured = write_shell(tmp_path / "a.ply", shell).checks
    calls = []
    count = quality.count_self_intersections
    monkeypatch.setattr(
        quality, "count_self_intersections", lambda *a: calls.append(1) or count(*a)
    )
    reused = write_shell(tmp_path / "b.ply", shell, crossing_free=True)
    assert reused.as_given and calls == [] and reused.checks == measured
    read = _shells.read_ply

    def moved(path):
        v, f = read(path)
        return v + np.where(np.arange(len(v)) == 0, 1e-6, 0.0)[:, None], f

    monkeypatch.setattr(_shells, "read_ply", moved)
    again = write_shell(tmp_path / "c.ply", shell, crossing_free=True)
    assert not again.as_given and calls == [1]
    assert again.checks["self_intersections"] == 0
