"""``shellvox view``: a local web viewer of a build's slices.

See :mod:`pipeline.viewer._server`.
"""
