"""Per-face layer thickness: face colours, the rule, its file, splitting faces.

- :mod:`~pipeline.thickness._face_colour` a robust CIELAB colour per face, with its spread;
- :mod:`~pipeline.thickness._rule` the thickness rule and its defaults;
- :mod:`~pipeline.thickness._rule_file` rules from TOML files;
- :mod:`~pipeline.thickness._face_thickness` the rule applied: thickness per face and layer;
- :mod:`~pipeline.thickness._face_split` faces split so the thickness can follow a texture.

Nothing here writes files (the thickness PLY is :func:`pipeline.output._ply.write_thickness_ply`).
"""
