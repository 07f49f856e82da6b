"""The coloured model every stage works on.

- :mod:`~pipeline.model.mesh` ``ColouredMesh`` and the one function that colours the surface;
- :mod:`~pipeline.model.texture` materials and texture sampling;
- :mod:`~pipeline.model.topology` seams merged, degenerate faces dropped, closed, oriented;
- :mod:`~pipeline.model.summary` what ``shellvox info`` reports.
"""
