"""glTF 2.0 / GLB: the reader, the checked document and the texture coordinates."""
