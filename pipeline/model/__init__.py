"""The coloured model every stage works on.

- :mod:`~pipeline.model._mesh` ``ColouredMesh`` and the one function that colours the surface;
- :mod:`~pipeline.model._texture` materials and texture sampling;
- :mod:`~pipeline.model._topology` seams merged, degenerate faces dropped, closed, oriented;
- :mod:`~pipeline.model._summary` what ``shellvox info`` reports.
"""
