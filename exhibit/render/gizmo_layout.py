"""Where the 4D axes gizmo's tips, letters and caption go in the HUD's top-right disc: the
letters placed apart so none covers another or the "4D axes" line.

Why apart from exhibit.render.layout: the gizmo's inner layout is its own; the panels' layout
only needs its disc."""

from __future__ import annotations

from collections.abc import Sequence

import math

import numpy as np

from exhibit.render.layout import HudLayout, Rect
from exhibit.render.text import line_height, text_width


#: Where an axis' tip is drawn, as a fraction of the gizmo's radius from its centre.
GIZMO_TIP = 0.78


def gizmo_tips(rotation: np.ndarray, layout: HudLayout) -> list[tuple[float, float]]:
    """The screen position of each axis' tip: the 4D rotation's columns seen along the eye's z
    (screen y down)."""
    cx, cy = layout.gizmo_center
    reach = GIZMO_TIP * layout.gizmo_radius
    return [(cx + reach * rotation[0, i], cy - reach * rotation[1, i]) for i in range(4)]


def gizmo_caption_rect(caption: str, layout: HudLayout) -> Rect:
    """The line under the gizmo ("4D axes"), centred, at the caption's size."""
    cx, cy = layout.gizmo_center
    px = layout.body_px
    w = text_width(caption, "sans", px)
    top = cy + layout.gizmo_radius + 0.1 * px
    return Rect(cx - w / 2, top, cx + w / 2, top + line_height("sans", px))


def gizmo_labels(
    rotation: np.ndarray, axes: Sequence[str], layout: HudLayout, caption: str = "4D axes"
) -> list[tuple[str, Rect]]:
    """Where each axis' letter goes: (letter, rectangle in whole pixels), in axis order.

    Letters placed beside their tips collide whenever two axes point the same way on screen
    (x over y, t over y), and two letters on top of each other read as neither. So each letter
    takes the free spot nearest to just beyond its tip along its axis (a few distances and
    directions around the tip), clear of the letters already placed and of the caption, inside
    the gizmo's disc if it can, else inside its block. The axes nearest the eye go first: their
    tips are drawn on top."""
    px = layout.body_px
    tips = gizmo_tips(rotation, layout)
    taken = [gizmo_caption_rect(caption, layout)]
    gap = max(2.0, 0.25 * px)  # letters on halos: apart by more than the halos
    out: dict[int, tuple[str, Rect]] = {}
    for i in np.argsort(-np.asarray(rotation)[2], kind="stable"):
        label = axes[i]
        rect = _free_label_spot(label, tips[i], layout, taken)
        out[int(i)] = (label, rect)
        taken.append(rect.grow(gap))
    return [out[i] for i in range(4)]


def _free_label_spot(
    label: str, tip: tuple[float, float], layout: HudLayout, taken: list[Rect]
) -> Rect:
    """The candidate rectangle for ``label`` nearest the ideal spot (just beyond ``tip``, away
    from the centre) that is clear of ``taken``: around the tip within the disc, then within
    the block, then anywhere on a grid over the block; the ideal spot itself if the block is
    full (never on a screen of sensible size)."""
    px = layout.body_px
    w, h = math.ceil(text_width(label, "bold", px)) + 2, line_height("bold", px)
    cx, cy = layout.gizmo_center
    tx, ty = tip
    outward = math.atan2(ty - cy, tx - cx) if math.hypot(tx - cx, ty - cy) > 0.15 * px else 0.0
    angles = outward + np.radians(np.arange(0, 360, 15))
    gaps = np.array([0.3, 0.8, 1.5, 2.3]) * px
    ux, uy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    reach = gaps[None, :] + np.abs(ux) * w / 2 + np.abs(uy) * h / 2
    around = np.stack([tx + ux * reach, ty + uy * reach], axis=-1).reshape(-1, 2)
    ideal = around[0]
    block, disc = layout.gizmo_block, layout.gizmo_radius + px

    def in_disc(rect: Rect) -> bool:
        return all(
            math.hypot(x - cx, y - cy) <= disc
            for x in (rect.x0, rect.x1)
            for y in (rect.y0, rect.y1)
        )

    def grid() -> np.ndarray:
        step = max(1.0, px / 4)
        xs, ys = np.meshgrid(
            np.arange(block.x0 + w / 2, block.x1 - w / 2 + 1, step),
            np.arange(block.y0 + h / 2, block.y1 - h / 2 + 1, step),
        )
        return np.stack([xs.ravel(), ys.ravel()], axis=-1)

    for centres, inside in (
        (lambda: around, in_disc),
        (lambda: around, block.contains),
        (grid, block.contains),
    ):
        points = centres()
        for x, y in points[np.argsort(np.hypot(*(points - ideal).T), kind="stable")]:
            rect = _pixel_rect(x - w / 2, y - h / 2, w, h)
            if block.contains(rect) and inside(rect) and not any(rect.overlaps(t) for t in taken):
                return rect
    return _pixel_rect(ideal[0] - w / 2, ideal[1] - h / 2, w, h)


def _pixel_rect(x: float, y: float, w: float, h: float) -> Rect:
    """A rectangle at whole pixels, as the glyphs are drawn (exhibit.render.renderer)."""
    x, y = round(x), round(y)
    return Rect(x, y, x + w, y + h)
