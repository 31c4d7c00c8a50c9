"""A tag's leader line: from the point it names to its label's nearest edge, and whether a line
passes through a rectangle. One definition for the HUD that places tags (exhibit.render.hud)
and for `--verify`, which checks them on the frame (exhibit.review.tags_seen)."""

from __future__ import annotations

from exhibit.render.layout import Rect

Segment = tuple[tuple[float, float], tuple[float, float]]


def leader(point: tuple[float, float], rect: Rect) -> Segment:
    """The leader as the HUD draws it: from the point to the label's nearest edge."""
    x, y = point
    return (x, y), (min(max(x, rect.x0), rect.x1), min(max(y, rect.y0), rect.y1))


def crosses(segment: Segment, rect: Rect) -> bool:
    """Whether the segment passes through the rectangle's inside (Liang-Barsky clipping)."""
    (x0, y0), (x1, y1) = segment
    dx, dy = x1 - x0, y1 - y0
    lo, hi = 0.0, 1.0
    for p, q in ((-dx, x0 - rect.x0), (dx, rect.x1 - x0), (-dy, y0 - rect.y0), (dy, rect.y1 - y0)):
        if p == 0:
            if q <= 0:
                return False
            continue
        u = q / p
        if p < 0:
            lo = max(lo, u)
        else:
            hi = min(hi, u)
        if lo >= hi:
            return False
    return hi - lo > 1e-9
