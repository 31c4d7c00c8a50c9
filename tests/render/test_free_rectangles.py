"""free_rectangles finds the same maximal rectangles, in the same order, as comparing every pair
of free rectangles does (the definition, kept here as the oracle)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.render.layout import Rect, free_rectangles


def oracle(size: tuple[int, int], panels: list[Rect], margin: float) -> list[Rect]:
    width, height = size
    screen = Rect(margin, margin, width - margin, height - margin)
    blocks = [p.grow(margin) for p in panels]
    xs = sorted({screen.x0, screen.x1, *[v for b in blocks for v in (b.x0, b.x1)]})
    ys = sorted({screen.y0, screen.y1, *[v for b in blocks for v in (b.y0, b.y1)]})
    xs = [x for x in xs if screen.x0 <= x <= screen.x1]
    ys = [y for y in ys if screen.y0 <= y <= screen.y1]
    free = [
        Rect(x0, y0, x1, y1)
        for x0 in xs
        for x1 in xs
        if x1 > x0
        for y0 in ys
        for y1 in ys
        if y1 > y0 and not any(Rect(x0, y0, x1, y1).overlaps(b) for b in blocks)
    ]
    maximal = [r for r in free if not any(o != r and o.contains(r) for o in free)]
    return sorted(maximal, key=lambda r: (-r.width * r.height, r))


panel = st.builds(
    lambda x, y, w, h: Rect(x, y, x + w, y + h),
    st.integers(-50, 700),
    st.integers(-50, 400),
    st.integers(1, 300),
    st.integers(1, 200),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(panel, max_size=6), st.sampled_from([0.0, 4.0, 12.5]))
def test_same_as_comparing_every_pair(panels, margin):
    size = (640, 360)
    found = free_rectangles(size, panels, margin)
    assert sorted(found, key=lambda r: (-r.width * r.height, r)) == oracle(size, panels, margin)
    areas = [r.width * r.height for r in found]
    assert areas == sorted(areas, reverse=True)


def test_the_screen_alone_is_one_rectangle():
    assert free_rectangles((100, 50), [], 5.0) == [Rect(5.0, 5.0, 95.0, 45.0)]
