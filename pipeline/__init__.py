"""shellvox pipeline: configuration, model loading, orchestration and the command line."""

__version__ = "0.1.0"
