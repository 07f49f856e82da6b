"""``shellvox view``: a local web viewer of a build's slices (see :mod:`pipeline.viewer.server`)."""
