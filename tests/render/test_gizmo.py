"""The 4D axes gizmo's letters: never on top of each other or of the "4D axes" line, always
inside the gizmo, whatever the rotation (pure layout; one GL check that the HUD draws them so)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit import scenes
from exhibit.geometry.view import ViewState
from exhibit.render import HudInfo, RenderOptions
from exhibit.render.gizmo_layout import gizmo_caption_rect, gizmo_labels, gizmo_tips
from exhibit.render.layout import hud_layout
from exhibit.surfaces.mesh import Mesh4D
from tests.hypothesis_profiles import examples

angle = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)
SIZES = [(1920, 1080), (1280, 720), (1024, 768), (480, 270), (320, 240)]
AXES = [("x", "y", "z", "w"), ("x", "y", "z", "t")]


def assert_apart(rotation, size, axes, caption="4D axes"):
    layout = hud_layout(size, "Title", ("caption",))
    placed = gizmo_labels(rotation, axes, layout, caption)
    assert [label for label, _ in placed] == list(axes)
    rects = [rect for _, rect in placed]
    for i, rect in enumerate(rects):
        assert layout.gizmo_block.contains(rect), (axes[i], rect, layout.gizmo_block)
        assert not rect.overlaps(gizmo_caption_rect(caption, layout)), axes[i]
        for j in range(i):
            assert not rect.overlaps(rects[j]), (axes[j], rects[j], axes[i], rect)


@settings(max_examples=examples(300), deadline=None)
@given(st.lists(angle, min_size=6, max_size=6), st.sampled_from(SIZES), st.sampled_from(AXES))
def test_no_two_gizmo_letters_overlap(angles, size, axes):
    assert_apart(ViewState(angles=tuple(angles)).rotation(), size, axes)


@pytest.mark.parametrize("size", SIZES)
def test_letters_of_coinciding_tips_are_separated(size):
    """x and y both along the eye's z: all four tips at two points (the issue's "x over y")."""
    rotation = np.eye(4)[:, [2, 3, 0, 1]]  # x, y -> eye z and w; z, w -> screen x, y
    layout = hud_layout(size, "Title", ("caption",))
    tips = gizmo_tips(rotation, layout)
    assert tips[0] == tips[1] == layout.gizmo_center
    assert_apart(rotation, size, ("x", "y", "z", "t"), "4D-Achsen")


def test_the_hud_draws_the_letters_where_the_layout_says(gl):
    gpu = gl.renderer.upload(Mesh4D())
    view = scenes.get("hopf").view.replace(angles=(0.3, 1.2, -0.4, 2.0, 0.1, -1.0))
    gl.image(gpu, view, (480, 270), RenderOptions(), HudInfo(axes=("x", "y", "z", "t")), samples=0)
    gpu.release()
    layout = gl.renderer.hud.layout
    assert gl.renderer.hud.gizmo_labels == gizmo_labels(
        view.rotation(), ("x", "y", "z", "t"), layout
    )
