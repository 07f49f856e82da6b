"""A picture of a model coloured by per-face thickness: four views and a colour bar (PNG).

Pure rendering from arrays to :class:`PIL.Image.Image` with matplotlib's object API (no
pyplot state): faces are drawn flat in the colour map's colour of their value, without
shading, so a colour in the picture reads straight off the colour bar (edges are drawn in
the face's own colour to close the seams). Faces turned away
from a view are left out (the mesh is closed), which also keeps matplotlib's
painter's-algorithm sorting honest.
"""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from numpy.typing import NDArray
from PIL import Image

#: (title, elevation, azimuth, axis seen end-on) of the views, degrees (matplotlib's
#: camera angles).
VIEWS = (
    ("oblique", 25.0, -60.0, ""),
    ("front (-y)", 0.0, -90.0, "y"),
    ("top (+z)", 90.0, -90.0, "z"),
    ("bottom (-z)", -90.0, -90.0, "z"),
)
#: Colour map of the thickness (perceptually uniform, readable in grey).
COLOUR_MAP = "viridis"


def thickness_image(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    values_mm: NDArray[np.float64],
    *,
    value_range: tuple[float, float],
    title: str = "",
    dpi: int = 100,
) -> Image.Image:
    """Render a closed mesh in four views, each face in the colour of its value.

    Parameters
    ----------
    vertices : (V, 3) float64, mm
    faces : (F, 3) int64
        Closed, outward-oriented.
    values_mm : (F,) float64, mm
        Value per face (the colour-layer thickness).
    value_range : (float, float), mm
        Values mapped to the two ends of the colour map (e.g. the rule's min and max).
    title : str, optional
        Figure title.
    dpi : int, optional
        Resolution of the 12 x 10 inch figure.

    Returns
    -------
    PIL.Image.Image
        RGB picture.
    """
    low, high = value_range
    norm = Normalize(vmin=low, vmax=high if high > low else low + 1e-9)
    colours = colormaps[COLOUR_MAP](norm(values_mm))
    triangles = vertices[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    centre = 0.5 * (lower + upper)
    half = 0.5 * float(np.max(upper - lower)) or 1.0

    figure = Figure(figsize=(12, 10), dpi=dpi)
    canvas = FigureCanvasAgg(figure)
    for index, (name, elevation, azimuth, end_on) in enumerate(VIEWS):  # loop over views
        axes = figure.add_subplot(2, 2, index + 1, projection="3d")
        e, a = np.radians(elevation), np.radians(azimuth)
        eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        facing = normals @ eye > 0
        axes.add_collection3d(
            Poly3DCollection(
                triangles[facing],
                facecolors=colours[facing],
                edgecolors=colours[facing],  # closes the hairline seams between faces
                linewidths=0.2,
                shade=False,
            )
        )
        axes.set_xlim(centre[0] - half, centre[0] + half)
        axes.set_ylim(centre[1] - half, centre[1] + half)
        axes.set_zlim(centre[2] - half, centre[2] + half)
        axes.set_box_aspect((1.0, 1.0, 1.0))
        axes.view_init(elev=elevation, azim=azimuth)
        axes.set_proj_type("ortho")
        axes.set_title(name)
        for axis in "xyz":
            if axis == end_on:
                getattr(axes, f"set_{axis}ticks")([])
            else:
                getattr(axes, f"set_{axis}label")(f"{axis} mm")
    figure.colorbar(
        ScalarMappable(norm=norm, cmap=COLOUR_MAP),
        ax=figure.axes,
        shrink=0.6,
        label="colour-layer thickness, mm",
    )
    if title:
        figure.suptitle(title)
    canvas.draw()  # type: ignore[no-untyped-call]
    rgba = np.asarray(canvas.buffer_rgba())  # type: ignore[no-untyped-call]
    return Image.fromarray(rgba[..., :3].copy(), "RGB")
