"""Framing by the picture, on the CPU: the lens shift moves the picture without changing it, a fit
puts the projected mesh inside the area it was given, and the HUD's free area keeps off every
panel (exhibit.geometry.framing, exhibit.render.layout)."""

import math

import numpy as np
import pytest

from exhibit.geometry import clip_transform
from exhibit.geometry.framing import Bounds, fit, frame, image_bounds, pixel_bounds
from exhibit.geometry.occlusion import hidden
from exhibit.geometry.view import ViewState
from exhibit.render.layout import Rect, free_rectangles, hud_layout

RNG = np.random.default_rng(7)
POINTS = RNG.normal(size=(500, 4))


@pytest.mark.parametrize("eye_r", [0.0, 1 / 9])
@pytest.mark.parametrize("sensor_r", [0.0, 1 / 6])
def test_lens_shift_translates_the_picture_exactly(eye_r, sensor_r):
    view = ViewState(
        angles=(0.3, -0.5, 0.2, 0.1, 0, 0), eye_r=eye_r, sensor_r=sensor_r, half_height=3.0
    )
    shifted = view.replace(center=(0.6, -0.4))
    a, ok_a = clip_transform(view, 16 / 9).to_pixels(POINTS * 0.3, 1920, 1080)
    b, ok_b = clip_transform(shifted, 16 / 9).to_pixels(POINTS * 0.3, 1920, 1080)
    both = ok_a & ok_b
    assert both.sum() > 100
    delta = b[both] - a[both]
    # One translation for every point: -0.6 / (3 * 16/9) of half the width, 0.4 / 3 of half
    # the height (y down).
    assert np.allclose(delta[:, 0], -0.6 / (3.0 * 16 / 9) * 960, atol=1e-6)
    assert np.allclose(delta[:, 1], -0.4 / 3.0 * 540, atol=1e-6)


@pytest.mark.parametrize("size", [(1920, 1080), (1280, 720)])
@pytest.mark.parametrize("eye_r", [0.0, 1 / 9])
def test_fit_puts_the_image_in_the_area(size, eye_r):
    view = ViewState(
        angles=(0.9, -0.8, -0.6, 0, 0, 0), eye_r=eye_r, sensor_r=1 / 6, half_height=2.6
    )
    area = (0.55 * size[0], 0.3 * size[1], 0.95 * size[0], 0.9 * size[1])
    framed = frame(view, POINTS, size, [area])
    x0, y0, x1, y1 = pixel_bounds(POINTS, framed, size)
    tol = 1e-6 * size[1]
    assert area[0] - tol <= x0 and x1 <= area[2] + tol
    assert area[1] - tol <= y0 and y1 <= area[3] + tol
    # ... and fills it along one side (it is as large as it can be).
    assert max((x1 - x0) / (area[2] - area[0]), (y1 - y0) / (area[3] - area[1])) > 0.999
    assert framed.angles == view.angles and framed.sensor_r == view.sensor_r


def test_fit_chooses_the_area_where_the_picture_is_largest():
    view = ViewState(eye_r=0.0, half_height=1.0)
    wide = Bounds(-2.0, -0.5, 2.0, 0.5)
    framed = fit(view, wide, (1000, 1000), [(0, 0, 300, 1000), (0, 600, 1000, 1000)])
    x0, y0, x1, y1 = pixel_bounds(
        np.array([[-2, -0.5, 0, 0], [2, 0.5, 0, 0.0]]), framed, (1000, 1000)
    )
    assert y0 >= 600 - 1e-6 and x1 - x0 == pytest.approx(1000)


def test_points_behind_the_sensor_do_not_count():
    view = ViewState(sensor_r=1 / 2, eye_r=0.0)
    points = np.array([[0.5, 0.5, 0, 0], [-0.5, -0.5, 0, 0], [9.0, 9.0, 0, 3.0]])
    b = image_bounds(points, view)
    assert b == Bounds(-0.5, -0.5, 0.5, 0.5)


@pytest.mark.parametrize("size", [(1920, 1080), (1280, 720), (1080, 1920)])
def test_free_rectangles_keep_off_every_panel(size):
    layout = hud_layout(
        size,
        "The offset of a cusp, and a circle that should not be there",
        ("A long caption " * 12,),
        drift=12,
    )
    rects = free_rectangles(size, layout.panels, layout.margin)
    assert rects
    for r in rects:
        assert r.x0 >= layout.margin and r.x1 <= size[0] - layout.margin
        assert r.y0 >= layout.margin and r.y1 <= size[1] - layout.margin
        for p in layout.panels:
            assert not r.overlaps(p.grow(layout.margin - 1e-9)), (r, p)
    # Maximal: the first (largest) cannot grow by a pixel on any side.
    big = rects[0]
    for grown in (
        big._replace(x0=big.x0 - 1),
        big._replace(x1=big.x1 + 1),
        big._replace(y0=big.y0 - 1),
        big._replace(y1=big.y1 + 1),
    ):
        screen = Rect(
            layout.margin, layout.margin, size[0] - layout.margin, size[1] - layout.margin
        )
        assert not screen.contains(grown) or any(
            grown.overlaps(p.grow(layout.margin)) for p in layout.panels
        )


def test_hidden_point_behind_a_square():
    from tests.render.conftest import square

    sheet = square("s", (0, 0, 0.0, 0), (1, 0, 0, 0), (0, 1, 0, 0), (1, 1, 1))
    view = ViewState(eye_r=0.0, half_height=1.0)
    ct = clip_transform(view, 1.0)
    points = np.array([[0.1, 0.1, -0.5, 0], [0.1, 0.1, 0.5, 0], [0.9, 0.9, -0.5, 0]])
    # z is towards the viewer: behind the square, in front of it, beside it.
    assert hidden(points, [sheet], ct).tolist() == [True, False, False]


def test_status_numbers_are_for_people():
    from exhibit.render.layout import status_lines

    view = ViewState(sensor_r=1 / 26163.17, angles=(math.radians(370), 0, 0, 0, 0, 0))
    lines = status_lines(view)
    assert "∞" in lines[2] and "26163" not in lines[2]
    assert "θ1   10.0°" in lines[0]
    near = status_lines(view.replace(sensor_r=1 / 2.7612))
    assert "2.76" in near[2] and len(near[2]) == len(lines[2])


def test_balanced_wrap_has_no_orphan_and_even_lines():
    from exhibit import scenes
    from exhibit.render.text import text_width, wrap, wrap_balanced

    title = scenes.get("offset-cusp").title
    # The case: greedy wrapping left "there" alone on the second line.
    assert wrap(title, "bold", 39, 0.62 * 1920)[-1] == "there"
    lines = wrap_balanced(title, "bold", 39, 0.62 * 1920)
    assert len(lines) == 2 and len(lines[-1].split()) > 1
    assert " ".join(lines) == title
    caption = scenes.get("collision").caption
    greedy = wrap(caption, "sans", 35, 700)
    balanced = wrap_balanced(caption, "sans", 35, 700)
    assert len(balanced) == len(greedy) and " ".join(balanced) == caption
    widths = [text_width(line, "sans", 35) for line in balanced]
    assert max(widths) <= 700
    # The greedy last line is a stub; balanced lines are within 20% of each other.
    assert min(widths) > 0.8 * max(widths)
    for width in (300, 450, 806, 2000):
        for text in (title, caption, "one", "two words"):
            lines = wrap_balanced(text, "sans", 35, width)
            assert " ".join(lines) == text
            assert len(lines) == 1 or len(lines[-1].split()) > 1 or len(lines[-2].split()) < 3, (
                text,
                width,
                lines,
            )


def test_curves_reach_only_a_little_beyond_the_surfaces():
    """A long axis must not shrink the surfaces: curve points count up to CURVE_REACH of the
    surfaces' extent beyond them; surfaces and markers count whole."""
    from exhibit.geometry.framing import CURVE_REACH, sample_bounds, to_pixels

    view = ViewState(eye_r=0.0)
    core = np.array([[-1.0, -1.0, 0, 0], [1.0, 1.0, 0, 0]])
    far = np.array([[0.0, -50.0, 0, 0], [0.0, 50.0, 0, 0], [1.2, 0.0, 0, 0]])
    b = sample_bounds((core, far), view)
    assert b == Bounds(-1.0, -1.0 - 2 * CURVE_REACH, 1.2, 1.0 + 2 * CURVE_REACH)
    assert sample_bounds((core, np.zeros((0, 4))), view) == Bounds(-1.0, -1.0, 1.0, 1.0)
    # to_pixels is the projection itself, at any zoom and lens shift.
    framed = view.replace(half_height=1.7, center=(0.3, -0.2))
    for size in ((1920, 1080), (1280, 720)):
        assert to_pixels(image_bounds(POINTS, framed), framed, size) == pytest.approx(
            pixel_bounds(POINTS, framed, size)
        )
