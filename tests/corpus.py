"""A corpus of small broken or awkward model files, written from the format specifications.

Each case is built into its own folder by its builder (:mod:`corpus_files`); the test says
what must happen: an ``InputError`` (one line, exit 2) or a ``ShellvoxWarning`` (one
line, exit 0). glTF and 3MF cases are in :mod:`corpus_containers`.
"""

from __future__ import annotations

from corpus_containers import CONTAINER_CASES
from corpus_files import (
    BIG,
    MTL_TEX,
    TEX,
    Case,
    obj_absolute_texture,
    obj_coordinates,
    obj_face,
    obj_outside_mtl,
    obj_outside_texture,
    obj_two_libraries_one_missing,
    obj_with,
    ply_with,
    png_header_only,
    random_stl,
)

CASES = [
    # OBJ + MTL
    Case(
        "obj texture outside the folder",
        obj_outside_texture,
        "error",
        ("x.png", "outside the model's folder", "--texture FILE", "--force"),
    ),
    Case(
        "obj texture outside the folder, --force",
        obj_outside_texture,
        "warning",
        ("x.png", "outside the model's folder", "--force"),
        ("--force",),
    ),
    Case("obj absolute texture path", obj_absolute_texture, "error", ("secret.png", "outside")),
    Case("obj mtllib outside the folder", obj_outside_mtl, "error", ("lib.mtl", "outside")),
    Case(
        "obj texture without vt",
        obj_with(MTL_TEX, image=TEX, uv=False),
        "warning",
        ("'painted'", "texture coordinates", "Kd"),
    ),
    Case(
        "obj --texture without vt",
        obj_with("newmtl painted\nKd 1 0 0\n", image=TEX, uv=False),
        "error",
        ("--texture", "texture coordinates"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj --texture not used",
        obj_with(MTL_TEX, image=TEX),
        "warning",
        ("--texture", "not used", "found"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj --texture on a model without map_Kd",
        obj_with("newmtl painted\nKd 1 0 0\n", image=TEX),
        "warning",
        ("--texture", "not used", "no map_Kd"),
        ("--texture", "FOLDER/tex.png"),
    ),
    Case(
        "obj usemtl not in the MTL",
        obj_with("newmtl other\nKd 1 0 0\n", material="painted"),
        "warning",
        ("'painted'", "not defined", "white"),
    ),
    Case(
        "obj malformed Kd",
        obj_with("newmtl painted\nKd 1 zero 0\n", uv=False),
        "error",
        ("model.mtl", "'painted'", "Kd", "1 zero 0"),
    ),
    Case(
        "obj Kd spectral",
        obj_with("newmtl painted\nKd spectral red.rfl\n", uv=False),
        "warning",
        ("'painted'", "spectral", "white"),
    ),
    Case(
        "obj map_Kd offset option",
        obj_with("newmtl painted\nmap_Kd -o 0.5 0.25 tex.png\n", image=TEX),
        "warning",
        ("-o 0.5 0.25", "not applied"),
    ),
    Case(
        "obj vertex colours beside a texture",
        obj_with(MTL_TEX, image=TEX, colours=True),
        "warning",
        ("vertex colours", "ignored"),
    ),
    Case(
        "obj one of two MTLs missing",
        obj_two_libraries_one_missing,
        "warning",
        ("gone.mtl", "missing"),
    ),
    Case(
        "obj texture of 13000 x 13000 pixels",
        obj_with(MTL_TEX, image=BIG),
        "error",
        ("13000x13000", "169,000,000 pixels", "--force"),
    ),
    Case(
        "obj texture of 20000 x 20000 pixels (past Pillow's bomb limit)",
        obj_with(MTL_TEX, image=png_header_only(20000, 20000)),
        "error",
        ("20000x20000", "--force"),
    ),
    Case(
        "obj truncated texture",
        obj_with(MTL_TEX, image=TEX[: len(TEX) // 2]),
        "error",
        ("tex.png", "unreadable", "--colour"),
    ),
    Case(
        "obj missing texture with --colour",
        obj_with("newmtl painted\nmap_Kd gone.png\n"),
        "warning",
        ("gone.png", "missing", "--colour 9,8,7"),
        ("--colour", "9,8,7"),
    ),
    Case("obj coordinate 1e300", obj_coordinates("1e300"), "error", ("far.obj", "1e+300 mm")),
    Case("obj coordinate 2e6", obj_coordinates("2e6"), "error", ("far.obj", "--force")),
    Case("obj coordinate inf", obj_coordinates("inf"), "error", ("far.obj", "infinite")),
    Case("obj coordinate nan", obj_coordinates("nan"), "error", ("far.obj", "NaN")),
    *(
        Case(f"obj face index {line}", obj_face(line), "error", ("index.obj", "out of range"))
        for line in (
            "f 1 2 99999999999999999999",
            "f 1 2 -99999999999999999999",
            "f 1/1 2/1 3/99999999999999999999",
            "f 1 2 9223372036854775807",
            "f 1 2 -9223372036854775808",
        )
    ),
    Case(
        "obj --scale overflowing to infinity",
        obj_coordinates("1e300"),
        "error",
        ("--scale", "infinity"),
        ("--scale", "1e10", "--force"),
    ),
    # PLY
    Case(
        "ply TextureFile missing",
        ply_with("gone.png"),
        "error",
        ("model.ply", "'gone.png'", "missing", "--colour"),
    ),
    Case(
        "ply TextureFile outside the folder",
        ply_with("../tex.png", image=TEX, where="tex.png"),
        "error",
        ("'../tex.png'", "outside the model's folder"),
    ),
    Case(
        "ply TextureFile without texture coordinates",
        ply_with("tex.png", image=TEX, uv=False),
        "warning",
        ("'tex.png'", "no texture coordinates"),
    ),
    Case(
        "ply colour properties trimesh does not read",
        ply_with(None, uv=False, extra="diffuse_red diffuse_green diffuse_blue"),
        "warning",
        ("diffuse_red", "not read as colour"),
    ),
    # STL
    Case("stl random bytes", random_stl, "error", ("blob.stl", "not a valid STL")),
    *CONTAINER_CASES,
]
