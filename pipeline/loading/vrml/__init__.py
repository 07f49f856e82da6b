"""VRML 2.0: the parser (:mod:`~pipeline.loading.vrml.parse`) and the reader."""
