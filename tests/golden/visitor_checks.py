"""What a visitor must always be able to see in a kiosk frame, checked on the CPU: the surfaces
clear of every text panel, and every marker label on the screen and off the panels.

Given a frame the kiosk drew on a HeadlessTarget, its HudLayout (``hud.layout`` of the target's
renderer) and its labels (``hud.labels``), and the same view drawn with the surfaces alone
(:func:`surfaces_alone`, as KioskRun.shot() does), :func:`visitor_problems` lists every problem
in one line each; an empty list is a frame a visitor can read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from exhibit.render.layout import HudLayout, Rect
from tests.golden.images import SURFACES_ONLY, surface_pixels_under_panels


@dataclass
class VisitorView:
    """One kiosk frame and what the checks need of it."""

    image: np.ndarray
    surfaces: np.ndarray  # the same view, surfaces alone on black
    layout: HudLayout
    labels: list = field(default_factory=list)  # (text, Rect, point, hidden)
    caption: str = ""
    mode: str = ""
    scene: str = ""


def surfaces_alone(headless, window) -> np.ndarray:
    """The latest frame of ``window`` (a HeadlessTarget) drawn again with its surfaces alone,
    on black, at the same quality."""
    gpu, view, options, _ = window.drawn
    return headless.frame(gpu, view, window.size, SURFACES_ONLY, quality=options.quality)


def capture(headless, window, caption: str = "", mode: str = "", scene: str = "") -> VisitorView:
    """The latest frame of the kiosk drawing into ``window``, with its layout and labels."""
    hud = headless.renderer.hud
    return VisitorView(
        window.image.copy(),
        surfaces_alone(headless, window),
        hud.layout,
        list(hud.labels),
        caption,
        mode,
        scene,
    )


def _overlap(a: Rect, b: Rect) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def label_problems(labels, layout: HudLayout, extra: tuple[Rect, ...] = ()) -> list[str]:
    """Each marker label off the screen or on a panel (where the panel may be with the
    burn-in drift), one line each."""
    width, height = layout.size
    out = []
    for text, rect, *_ in labels:
        if not (rect.x0 >= 0 and rect.x1 <= width and rect.y0 >= 0 and rect.y1 <= height):
            out.append(f"label {text!r} at {_box(rect)} is not inside the {width}x{height} screen")
        for panel in [*layout.panels, *extra]:
            if _overlap(rect, panel):
                out.append(f"label {text!r} at {_box(rect)} is on the panel {_box(panel)}")
    return out


def visitor_problems(view: VisitorView, extra: tuple[Rect, ...] = ()) -> list[str]:
    """Every reason a visitor cannot read ``view``: surface pixels under a panel (``extra``:
    more rectangles that count as panels, e.g. the time-slice inset), labels off the screen or
    on a panel."""
    panels = [*view.layout.panels, *extra]
    return surface_pixels_under_panels(view.surfaces, panels) + label_problems(
        view.labels, view.layout, extra
    )


def _box(rect: Rect) -> tuple[int, ...]:
    return tuple(math.floor(v) if i < 2 else math.ceil(v) for i, v in enumerate(rect))
