"""VRML 2.0: the parser (:mod:`~pipeline.loading.vrml._parse`) and the reader."""
