"""The glTF / GLB and 3MF cases of the corpus (see :mod:`corpus`)."""

from __future__ import annotations

from builders import embed_image
from corpus_files import (
    BIG,
    TEX,
    Case,
    glb_with,
    gltf_image,
    gltf_missing_buffer,
    gltf_outside_buffer,
    model_xml,
    set_key,
    threemf,
    threemf_bad_crc,
    threemf_missing_texture,
    threemf_unknown_texid,
    truncated_glb,
)

CONTAINER_CASES = [
    # glTF / GLB
    Case(
        "gltf image missing",
        gltf_image("gone.png"),
        "error",
        ("model.gltf", "'gone.png'", "missing", "--colour"),
    ),
    Case(
        "gltf image missing with --colour",
        gltf_image("gone.png"),
        "warning",
        ("'gone.png'", "missing", "--colour 10,20,30"),
        ("--colour", "10,20,30"),
    ),
    Case(
        "gltf image unreadable",
        gltf_image("bad.png", data=b"not an image at all"),
        "error",
        ("'bad.png'", "unreadable"),
    ),
    Case(
        "gltf image outside the folder",
        gltf_image("../secret.png", data=TEX, where="secret.png"),
        "error",
        ("'../secret.png'", "outside the model's folder", "--force"),
    ),
    Case(
        "gltf image by absolute path",
        gltf_image("FOLDER/secret.png", data=TEX, where="secret.png"),
        "error",
        ("secret.png", "outside the model's folder"),
    ),
    Case(
        "gltf image remote",
        gltf_image("https://example.com/x.png"),
        "error",
        ("remote URI", "download"),
    ),
    Case(
        "glb buffer declaring 1e12 bytes",
        glb_with(set_key(("buffers", 0, "byteLength"), 10**12)),
        "error",
        ("1,000,000,000,000 bytes", "BIN chunk"),
    ),
    Case(
        "glb bufferView past the buffer",
        glb_with(set_key(("bufferViews", 1, "byteLength"), 10**6)),
        "error",
        ("bufferView 1", "past the end"),
    ),
    Case(
        "glb accessor past its bufferView",
        glb_with(set_key(("accessors", 0, "count"), 10**6)),
        "error",
        ("accessor 0", "bufferView 0"),
    ),
    Case(
        "glb data-less accessor of 1e12 items",
        glb_with(
            set_key(("accessors", 1), {"componentType": 5126, "count": 10**12, "type": "VEC2"})
        ),
        "error",
        ("accessor 1", "--force"),
    ),
    Case(
        "glb embedded texture of 13000 x 13000 pixels",
        glb_with(embed_image(BIG), image={}),
        "error",
        ("13000x13000", "--force"),
    ),
    Case(
        "glb malformed baseColorFactor",
        glb_with(lambda d, b: (d, b), factor=["red", 0, 0, 1]),
        "error",
        ("'painted'", "baseColorFactor"),
    ),
    Case(
        "glb texture on TEXCOORD_1",
        glb_with(embed_image(TEX), image={}, tex_coord=1),
        "warning",
        ("'painted'", "TEXCOORD_1", "baseColorFactor"),
    ),
    Case(
        "glb malformed KHR_texture_transform",
        glb_with(
            embed_image(TEX),
            image={},
            texture_extensions={"KHR_texture_transform": {"scale": [2, "x"]}},
        ),
        "error",
        ("'painted'", "KHR_texture_transform scale", "2 numbers"),
    ),
    Case("glb truncated", truncated_glb, "error", ("cut.glb", "truncated")),
    Case(
        "glb with --texture",
        glb_with(embed_image(TEX), image={}),
        "warning",
        ("--texture applies to OBJ files only", "model.glb"),
        ("--texture", "FOLDER/model.glb"),  # any existing file: it is never read
    ),
    Case(
        "glb with a string where a material belongs",
        glb_with(set_key(("materials", 0), "painted")),
        "error",
        ("model.glb", "malformed glTF document"),
    ),
    Case(
        "glb primitive with a material index out of range",
        glb_with(set_key(("meshes", 0, "primitives", 0, "material"), 7)),
        "error",
        ("model.glb", "malformed glTF document"),
    ),
    Case("gltf buffer file missing", gltf_missing_buffer, "error", ("'gone.bin'", "missing")),
    Case(
        "gltf buffer outside the folder",
        gltf_outside_buffer,
        "error",
        ("'../outside.bin'", "outside the model's folder"),
    ),
    # 3MF
    Case("3mf broken _rels/.rels", threemf(model_xml(), rels="<Rel"), "error", ("_rels/.rels",)),
    Case("3mf bad CRC", threemf_bad_crc, "error", ("3D/3dmodel.model", "corrupt")),
    Case(
        "3mf bad colour",
        threemf(model_xml(colour="#GGHHII")),
        "error",
        ("'#GGHHII'", "#RRGGBB"),
    ),
    Case(
        "3mf transform of 11 numbers",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 1 0 0")),
        "error",
        ("malformed transform", "12 numbers"),
    ),
    Case(
        "3mf non-numeric transform",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 one 0 0 0")),
        "error",
        ("malformed transform",),
    ),
    Case(
        "3mf singular transform",
        threemf(model_xml(transform="1 0 0 0 1 0 0 0 0 0 0 0")),
        "error",
        ("singular transform",),
    ),
    Case(
        "3mf non-numeric vertex coordinate",
        threemf(model_xml(vertex='x="zero" y="0" z="0"')),
        "error",
        ("vertex coordinate", "'zero'"),
    ),
    Case(
        "3mf infinite vertex coordinate",
        threemf(model_xml(vertex='x="inf" y="0" z="0"')),
        "error",
        ("m.3mf", "infinite"),
    ),
    Case("3mf unknown texid", threemf_unknown_texid, "error", ("'99'", "unknown texture")),
    Case(
        "3mf composite materials",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<m:compositematerials id="5" matid="2" matindices="0">'
                '<m:composite values="1"/></m:compositematerials><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="5" p1="0"')
        ),
        "error",
        ("composite materials '5'", "unknown base materials '2'"),
    ),
    Case(
        "3mf composite materials of base materials",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<basematerials id="3"><base name="a" displaycolor="#FF0000"/>'
                '<base name="b" displaycolor="#0000FF"/></basematerials>'
                '<m:compositematerials id="5" matid="3" matindices="0 1">'
                '<m:composite values="1 3"/></m:compositematerials><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="5" p1="0"')
        ),
        "warning",
        ("compositematerials", "display colour", "no per-face material ratios"),
    ),
    Case(
        "3mf multiproperties with a malformed blend method",
        threemf(
            model_xml()
            .replace(
                '<object id="1"',
                '<m:multiproperties id="6" pids="2 2" blendmethods="screen">'
                '<m:multi pindices="0 0"/></m:multiproperties><object id="1"',
            )
            .replace('pid="2" p1="0"', 'pid="6" p1="0"')
        ),
        "error",
        ("multiproperties '6'", "blendmethods", "'screen'"),
    ),
    Case(
        "3mf p:path to a missing model part",
        threemf(
            model_xml().replace(
                '<build><item objectid="1"/>',
                '<build><item objectid="1" p:path="/3D/Objects/gone.model" '
                'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06"/>',
            )
        ),
        "error",
        ("p:path", "'/3D/Objects/gone.model'"),
    ),
    Case(
        "3mf texture missing from the package",
        threemf_missing_texture,
        "error",
        ("gone.png", "missing", "--colour"),
    ),
    Case(
        "3mf texture missing, --colour",
        threemf_missing_texture,
        "warning",
        ("gone.png", "missing", "--colour 1,2,3"),
        ("--colour", "1,2,3"),
    ),
]
