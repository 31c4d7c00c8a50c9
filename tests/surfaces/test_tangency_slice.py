"""The slice at the moment of tangency (issue 22): rc = rs = 1, vc = 0, vs = 1 at t = 0 the ball
touches the pipe along the whole circle x = 0, y² + z² = 1. The hyperplane t = 0 is tangent to
the collision surface there (t ≤ 0 on the sheet z > 0), so the mesh's zero set of t is empty;
before, `exhibit slice` gave 0 curves and `touching_curves` 153 fragments."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit import scenes
from exhibit.scenes.collision import touching_curves
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.slice import slice_curves

FIGURE_15 = {"rc": 1.0, "rs": 1.0, "vc": 0.0, "vs": 1.0}


def _on_both(points, p, c):
    x, y, z, t = points.T
    pipe = (y - p["vc"] * c) ** 2 + z**2 - p["rc"] ** 2
    ball = x**2 + y**2 + (z + p["vs"] * c) ** 2 - p["rs"] ** 2
    return max(np.abs(pipe).max(), np.abs(ball).max(), np.abs(t - c).max())


@pytest.mark.parametrize(
    "p, resolution",
    [
        (FIGURE_15, 24),
        # At the scene's resolution the mesh has vertices on the singular points, on the
        # hyperplane: their sign-change loop duplicated 4 points of the circle as a curve.
        (FIGURE_15, 48),
        ({"rc": 0.8, "rs": 0.8, "vc": 0.0, "vs": 0.6}, 24),
    ],
)
def test_the_tangency_slice_is_one_closed_circle(p, resolution):
    scenes.load()
    surface = scenes.get("collision").build(p, resolution).surfaces[0]
    stats = RefineStats()
    curves = slice_curves(surface, 3, 0.0, stats)
    assert len(curves) == 1 and curves[0].closed
    points = curves[0].points
    assert _on_both(points, p, 0.0) < 1e-9
    assert np.abs(points[:, 0]).max() < 1e-5  # x = 0: the circle, to √ε (a double zero)
    # it goes all the way round: no gap longer than a few cells
    angle = np.sort(np.arctan2(points[:, 2], points[:, 1]))
    assert np.diff(np.concatenate([angle, [angle[0] + 2 * np.pi]])).max() < 0.3


@pytest.mark.parametrize("c", [0.0, 1e-3, -1e-3])
def test_touching_curves_at_tangency_is_one_closed_curve(c):
    curves = touching_curves(FIGURE_15, c)
    assert len(curves) == 1 and curves[0].closed
    assert _on_both(curves[0].points, FIGURE_15, c) < 1e-9
