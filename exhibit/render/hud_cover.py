"""What the HUD covers of the picture: its panels, glyphs (halos included), lines and discs, as
drawn in one frame, and that as a mask of pixels.

Why: a caption's claim about the picture is a claim about what a visitor sees. The object-id
pass counts an object's pixels in front of the others, but a panel, a tag or a word may lie over
them (the title, numbers and gizmo panels cover about a fifth of the screen), so the claims
count only the pixels no part of the HUD covers (exhibit.review.claims). Pure: no GL."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from exhibit.render.layout import Rect

#: A line or disc as the overlay draws it: end points in pixels (x right, y down) and its
#: full width (a disc: both ends the same point, the width its diameter).
Capsule = tuple[tuple[float, float], tuple[float, float], float]
#: What is drawn at least this opaque hides the picture behind it (a word fading in or out
#: over a crossfade does not, yet).
OPAQUE = 0.5
#: The overlay's lines and discs fade out over about a pixel beyond their width.
EDGE_PX = 1.0


@dataclass(frozen=True)
class HudCover:
    """The rectangles (panels, glyph quads, the title panel) and capsules (leaders, discs,
    the gizmo) one HUD drew, in screen pixels."""

    rects: tuple[Rect, ...] = ()
    capsules: tuple[Capsule, ...] = ()

    @classmethod
    def of(cls, title: Rect | None, rows: Sequence[tuple], items: Sequence[tuple]) -> HudCover:
        """From what Hud.draw handed the GPU: the title panel's rectangle, the glyph and panel
        quads ``rows`` (x, y, w, h, ...) and the overlay ``items`` (a, b, rgba, width); what is
        drawn less than half opaque (a crossfade's fading words) covers nothing."""
        rects = [title] if title is not None else []
        rects += [Rect(r[0], r[1], r[0] + r[2], r[1] + r[3]) for r in rows if r[11] >= OPAQUE]
        capsules = [(a, b, float(w)) for a, b, rgba, w in items if rgba[3] >= OPAQUE]
        return cls(tuple(rects), tuple(capsules))

    def mask(self, screen: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
        """(height, width) booleans at ``size``, top row first: True where the HUD drawn on a
        ``screen`` covers the pixel's centre."""
        width, height = int(size[0]), int(size[1])
        sx, sy = width / float(screen[0]), height / float(screen[1])
        out = np.zeros((height, width), dtype=bool)
        for r in self.rects:
            x0, x1 = _span(r.x0 * sx, r.x1 * sx, width)
            y0, y1 = _span(r.y0 * sy, r.y1 * sy, height)
            out[y0:y1, x0:x1] = True
        for (ax, ay), (bx, by), w in self.capsules:
            reach = 0.5 * w + EDGE_PX
            x0, x1 = _span((min(ax, bx) - reach) * sx, (max(ax, bx) + reach) * sx, width)
            y0, y1 = _span((min(ay, by) - reach) * sy, (max(ay, by) + reach) * sy, height)
            if x0 >= x1 or y0 >= y1:
                continue
            # pixel centres, back in screen pixels
            px = (np.arange(x0, x1) + 0.5) / sx
            py = (np.arange(y0, y1) + 0.5) / sy
            gx, gy = np.meshgrid(px, py)
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            u = np.clip(((gx - ax) * dx + (gy - ay) * dy) / length2, 0, 1) if length2 else 0.0
            near = np.hypot(gx - (ax + u * dx), gy - (ay + u * dy)) <= reach
            out[y0:y1, x0:x1] |= near
        return out


def _span(a: float, b: float, n: int) -> tuple[int, int]:
    """The pixels whose centres lie in [a, b), clipped to 0..n."""
    return min(max(int(np.ceil(a - 0.5)), 0), n), min(max(int(np.ceil(b - 0.5)), 0), n)
