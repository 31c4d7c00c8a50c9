"""A curve behind a surface is hidden where its centre line is: a wide curve running just
behind a surface's outline showed its rim beyond the outline as a sliver (Figures 9 and 10: a
1-px red line along the tube's outline), since the depth test sees nothing there."""

from __future__ import annotations

import numpy as np

from exhibit.geometry import ViewState
from exhibit.render import RenderOptions
from exhibit.surfaces.mesh import Curve, Material, Mesh4D
from tests.render.conftest import square

SIZE = (160, 160)
VIEW = ViewState(angles=(0.0,) * 6, sensor_r=0.0, eye_r=0.0, half_height=1.0)
OPTIONS = RenderOptions(
    silhouettes=False,
    pinch_points=False,
    hud=False,
    line_scale=1.0,
    background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
)


def scene(depth: float) -> Mesh4D:
    """A grey square x, y in [-0.5, 0.5] at z = 0, and a red curve 8 px wide at z = ``depth``
    (negative: behind, from the eye on +z) whose centre runs 2 px inside the square's right edge."""
    grey = square("front", (0, 0, 0, 0), (1, 0, 0, 0), (0, 1, 0, 0), (0.5, 0.5, 0.5))
    x = 0.5 - 2.0 / 80.0  # 80 px to a unit at this size
    points = np.array([[x, -0.4, depth, 0.0], [x, 0.4, depth, 0.0]])
    red = Curve("behind", points, material=Material(color=(1.0, 0.0, 0.0), line_width=8.0))
    return Mesh4D([grey], curves=[red])


def red_pixels(headless, depth: float) -> int:
    gpu = headless.renderer.upload(scene(depth))
    image = headless.draw_frame(gpu, VIEW, SIZE, OPTIONS).read().astype(int)
    gpu.release()
    return int(((image[..., 0] > 120) & (image[..., 1] < 60) & (image[..., 2] < 60)).sum())


def test_a_curve_behind_an_outline_leaves_no_sliver(gl):
    assert red_pixels(gl, -0.3) == 0


def test_a_curve_in_front_of_the_outline_is_drawn_whole(gl):
    assert red_pixels(gl, 0.3) > 8 * 60
