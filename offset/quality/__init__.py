"""How good shells are: distance to the surface, validity, nesting, and the report.

- :mod:`~shellvox.offset.quality.measures` equidistance, mesh checks, nesting;
- :mod:`~shellvox.offset.quality.baselines` the vertex-normal and slicer baselines;
- :mod:`~shellvox.offset.quality.report` the JSON report of ``shellvox shells``.
"""
