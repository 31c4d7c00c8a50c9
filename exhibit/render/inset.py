"""The time-slice inset: a picture in the picture that shows the 3D world at the slice value.

The main picture shows the 4D surface with its slice S ∩ {x_a = c} glowing on it
(ViewState.slice_axis/slice_at). The inset shows what that slice *is* in 3D: for a scene with a
world at a moment (Scene.world_at: the collision's pipe and ball at time c) that world with the
slice as the curve where they meet; for any other scene the slice curves alone. It is drawn with
the sensor at infinity along the sliced axis (so the 3D world is seen as it is) and the main
view's eye, so both pictures turn together. It sits in the bottom-right corner and counts as a
panel, so the main picture is framed into the space left free by the text and by it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from exhibit.geometry.framing import frame, mesh_points
from exhibit.geometry.view import ViewState
from exhibit.render.layout import Rect
from exhibit.render.options import RenderOptions
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.mesh import Curve, Mesh4D
from exhibit.surfaces.slice import SLICE_MATERIAL, slice_curves

if TYPE_CHECKING:
    from exhibit.scenes.base import Scene

#: The inset's height as a fraction of the screen's, and its aspect.
HEIGHT = 0.36
ASPECT = 4.0 / 3.0
#: Its own picture: a background a shade lighter than the screen's, so it reads as a window;
#: no HUD. Its border (rgba).
OPTIONS = RenderOptions(
    hud=False,
    pinch_points=False,
    intersections=False,
    background=((0.22, 0.24, 0.30), (0.10, 0.11, 0.15)),
)
BORDER = (0.80, 0.82, 0.88, 1.0)
#: The label's colour and the dark tab it sits on in the corner (a light picture may lie behind
#: it): at least 7:1 over white (tests/golden/test_contrast.py).
LABEL = (0.90, 0.91, 0.94, 1.0)
TAB = (0.0, 0.0, 0.0, 0.88)


def inset_rect(size: tuple[int, int], margin: float) -> Rect:
    """Where the inset goes: the bottom-right corner, inside the margin."""
    width, height = size
    h = round(HEIGHT * height)
    w = round(min(ASPECT * h, 0.45 * width))
    return Rect(width - margin - w, height - margin - h, width - margin, height - margin)


def _last_axis(points: np.ndarray, axis: int) -> np.ndarray:
    """Coordinates reordered so the sliced axis comes last (the one the sensor projects away)."""
    order = [k for k in range(4) if k != axis] + [axis]
    return points[..., order]


def inset_mesh(
    scene: Scene, params: dict, mesh: Mesh4D, axis: int, at: float, stats: RefineStats | None = None
) -> Mesh4D:
    """The 3D world at the slice: Scene.world_at's when the scene has one for this axis (with
    its own touching curve: the collision's in closed form, cheap enough for every frame of a
    kiosk); else the slice curves alone, traced and refined on the mesh."""
    if scene.world_at is not None and scene.slice_axis == axis:
        return scene.world_at(params, at)  # with the touching curve, in closed form
    curves = [
        Curve(c.name, c.points, SLICE_MATERIAL, c.closed)
        for surface in mesh.surfaces
        for c in slice_curves(surface, axis, at, stats)
    ]
    return Mesh4D(
        [], [Curve(c.name, _last_axis(c.points, axis), c.material, c.closed) for c in curves]
    )


def inset_label(axis_name: str, at: float) -> str:
    """The inset's label: the moment it shows."""
    return f"{axis_name} = {at:+.2f}"


def inset_view(main: ViewState, mesh: Mesh4D | np.ndarray, size: tuple[int, int]) -> ViewState:
    """No 4D rotation and the sensor at infinity (the sliced axis is dropped, the 3D world is
    seen undistorted), the main view's eye, framed into the inset with a margin. ``mesh`` may
    be points instead: the worlds of several moments, so the frame holds still while time
    moves (the kiosk)."""
    view = ViewState(
        eye_azimuth=main.eye_azimuth,
        eye_incidence=main.eye_incidence,
        twist=main.twist,
        eye_r=main.eye_r,
        lights=main.lights,
    )
    points = mesh if isinstance(mesh, np.ndarray) else mesh_points(mesh)
    if len(points) == 0:
        return view
    margin = 0.08 * min(size)
    area = (margin, margin, size[0] - margin, size[1] - margin)
    return frame(view, points, size, [area])
