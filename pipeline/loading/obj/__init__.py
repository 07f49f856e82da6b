"""Wavefront OBJ: the reader and the MTL material libraries it names."""
