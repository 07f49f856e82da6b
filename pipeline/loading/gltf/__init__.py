"""glTF 2.0 / GLB: the reader, the checked document and the texture coordinates."""

from __future__ import annotations

from shellvox.loading.gltf._reader import read_gltf

__all__ = [
    "read_gltf",
]
