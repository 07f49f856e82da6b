"""3MF: the package, property groups, multiproperties, slicer paint and the reader."""
