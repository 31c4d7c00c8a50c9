"""The kiosk's time-slice inset shows the world at the exact moment (issue 32): next to Figure
15's tangency the touching curve changes within 1e-6 of t = 0 (all round the pipe at t = 0, only
below its axis just after), and a moment rounded to 4 decimals showed the one before."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from exhibit import scenes
from exhibit.geometry.view import ViewState
from exhibit.kiosk.slice_inset import SliceInset
from exhibit.render.layout import Rect

FIGURE_15 = (("rc", 1.0), ("rs", 1.0), ("vc", 0.0), ("vs", 1.0))


class Uploaded:
    def __init__(self, world):
        self.world = world

    def release(self) -> None:
        pass


def touching_points(inset: SliceInset, at: float) -> np.ndarray:
    frame = SimpleNamespace(
        scene="collision", params=FIGURE_15, view=ViewState(slice_axis=3, slice_at=at)
    )
    shown = inset.for_frame(frame, None)
    assert shown is not None
    curves = [c for c in shown.gpu.world.curves if c.name.startswith("slice")]
    return np.concatenate([c.points for c in curves])


def test_the_inset_follows_the_moment_to_the_last_digit():
    scenes.load()
    inset = SliceInset(Rect(0, 0, 320, 240), Uploaded)
    at_tangency = touching_points(inset, 0.0)
    assert at_tangency[:, 2].max() > 0.99  # the whole circle: the top of the pipe too
    after = touching_points(inset, 1e-6)
    assert np.all(after[:, 3] == 1e-6)
    assert after[:, 2].max() <= 0.0  # z = −(x² + c²)/2c: only below the axis
