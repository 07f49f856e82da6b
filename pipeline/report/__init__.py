"""Pictures of a result: the previews of a build folder, the thickness picture."""

from __future__ import annotations

from shellvox.report._previews import write_previews
from shellvox.report._thickness_picture import COLOUR_MAP, thickness_image

__all__ = [
    "COLOUR_MAP",
    "thickness_image",
    "write_previews",
]
