"""Where a marker's label or a tag's words go on the screen: beside the point, off the panels
and other labels, off the picture where there is room, and (for tags) where its leader crosses
no other tag. Pure layout: no GL."""

from __future__ import annotations

import math
from collections.abc import Callable

from exhibit.render.layout import HudLayout, Rect, free_rectangles
from exhibit.render.text import line_height, text_width


def marker_text(label: str, word: Callable[[str], str]) -> str:
    """A marker's label in the language on screen: labels are words, then a formula after a
    comma ("first contact, t = 0.123", exhibit.scenes.collision); ``word`` translates the
    words, the formula reads the same in every language."""
    words, comma, formula = label.partition(", ")
    return word(words) + comma + formula


def place_beside(
    text: str,
    point: tuple[float, float],
    px: int,
    layout: HudLayout,
    taken: list[Rect],
    picture: Rect | None,
    clear: Callable[[Rect], bool] | None = None,
) -> Rect:
    """:func:`place_label` off the ``picture`` too, where there is room for it; else on the
    picture (it fills the screen), still off everything in ``taken``; ``clear``: what else a
    place must be (a tag's leader crossing no other tag's)."""
    if picture is None:
        return place_label(text, point, px, layout, taken, clear)
    label = place_label(text, point, px, layout, [*taken, picture], clear)
    if any(label.overlaps(t) for t in (*taken, picture)) or (clear and not clear(label)):
        label = place_label(text, point, px, layout, taken, clear)
    return label


def place_label(
    text: str,
    point: tuple[float, float],
    px: int,
    layout: HudLayout,
    taken: list[Rect],
    clear: Callable[[Rect], bool] | None = None,
) -> Rect:
    """Where a marker's label goes: the first of a few places around the point, nearest first,
    that lies on the screen (inside the margin) and clear of every rectangle in ``taken``
    (panels, other labels); else the place in the free area nearest the point."""
    width, height = layout.size
    w = text_width(text, "bold", px) + 0.5 * px
    h = line_height("bold", px)
    x, y = point
    screen = Rect(layout.margin, layout.margin, width - layout.margin, height - layout.margin)
    candidates = []
    for d in (0.6, 2.0, 4.0, 7.0):
        gap = d * px
        candidates += [
            (x + gap, y - h - 0.3 * gap),
            (x + gap, y + 0.3 * gap),
            (x - gap - w, y - h - 0.3 * gap),
            (x - gap - w, y + 0.3 * gap),
            (x - w / 2, y - h - gap),
            (x - w / 2, y + gap),
        ]
    for cx, cy in candidates:
        rect = Rect(cx, cy, cx + w, cy + h)
        free = screen.contains(rect) and not any(rect.overlaps(t) for t in taken)
        if free and (clear is None or clear(rect)):
            return rect
    # Everything near is taken: the nearest spot of the largest free rectangles (one that is
    # ``clear`` where there is one).
    spots = []
    for area in free_rectangles(layout.size, taken, layout.margin / 2):
        if area.width < w or area.height < h:
            continue
        cx = min(max(x - w / 2, area.x0), area.x1 - w)
        cy = min(max(y - h / 2, area.y0), area.y1 - h)
        spots.append((math.hypot(cx + w / 2 - x, cy + h / 2 - y), Rect(cx, cy, cx + w, cy + h)))
    spots.sort(key=lambda spot: spot[0])
    for _, rect in spots:
        if clear is None or clear(rect):
            return rect
    if spots:
        return spots[0][1]
    cx = min(max(x, screen.x0), screen.x1 - w)
    cy = min(max(y, screen.y0), screen.y1 - h)
    return Rect(cx, cy, cx + w, cy + h)
