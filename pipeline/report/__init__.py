"""Pictures of a result: the previews of a build folder, the thickness picture."""

from __future__ import annotations

from pipeline.report._previews import write_previews
from pipeline.report._thickness_picture import COLOUR_MAP, thickness_image

__all__ = [
    "COLOUR_MAP",
    "thickness_image",
    "write_previews",
]
