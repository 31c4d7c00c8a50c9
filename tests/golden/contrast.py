"""Text contrast measured on the frame (WCAG 2.x): every word on screen must have a contrast
ratio of at least 7:1 (AAA) against the pixels actually behind it.

The HUD keeps the text it drew (``renderer.hud.texts``, the inset's label in
``pipeline.texts``): each piece's kind, words, glyph box and colour. The same frame is drawn a
second time with every glyph left out (``hud.ink = False``: panels, halos, the gizmo's disc and
lines, the picture all stay), which is what lies behind the text. Inside each glyph box the ink
is where the two frames differ (by at least a quarter of the way to the glyph colour); its
footprint, grown by the pixels beside it (the edges a reader sees
the strokes against), is the background measured: the worst pixel there (the lightest behind light
text) against the glyph colour, composited over it with the alpha it is drawn with, gives the
element's ratio. A piece whose ink cannot be found at all is measured against its whole box.

Pure numpy on the frames; the WCAG ratio is exhibit.scenes.colours.contrast_ratio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exhibit.scenes.colours import contrast_ratio

#: The rule: WCAG 2.x AAA for text.
MINIMUM = 7.0
#: A pixel is ink where the two frames differ by more than this in any channel (0..1) and the
#: glyph covers at least COVERED of it (the faint antialiased rim of a stroke is not measured;
#: the pixels beside every covered one are).
INK_DIFFERENCE = 6.0 / 255.0
COVERED = 0.25


@dataclass(frozen=True)
class Measured:
    kind: str
    text: str
    rect: tuple[int, int, int, int]
    ratio: float
    background: tuple[float, float, float]  # the worst pixel behind it, 0..1
    pixels: int  # background pixels measured

    def __str__(self) -> str:
        bg = "#" + "".join(f"{round(255 * c):02x}" for c in self.background)
        return f"{self.kind} {self.text!r} at {self.rect}: {self.ratio:.2f}:1 against {bg}"


def _grow(mask: np.ndarray) -> np.ndarray:
    """``mask`` and the pixels beside it (left, right, above, below)."""
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    return out


def measure(image: np.ndarray, background: np.ndarray, texts) -> list[Measured]:
    """Each text element's worst contrast: ``image`` the frame, ``background`` the same frame
    with the glyphs left out (both (h, w, 3) uint8, top row first), ``texts`` TextMarks."""
    h, w = image.shape[:2]
    img = image[..., :3].astype(np.float64) / 255.0
    bg = background[..., :3].astype(np.float64) / 255.0
    out = []
    for mark in texts:
        x0, y0 = max(0, int(np.floor(mark.rect.x0))), max(0, int(np.floor(mark.rect.y0)))
        x1, y1 = min(w, int(np.ceil(mark.rect.x1))), min(h, int(np.ceil(mark.rect.y1)))
        if x1 <= x0 or y1 <= y0 or not mark.text.strip():
            continue
        a, b = img[y0:y1, x0:x1], bg[y0:y1, x0:x1]
        rgb, alpha = np.asarray(mark.rgba[:3], dtype=np.float64), float(mark.rgba[3])
        # the glyph's coverage of each pixel: how far the ink moved it toward the ink colour
        full = alpha * np.abs(rgb - b).max(axis=-1)
        moved = np.abs(a - b).max(axis=-1)
        ink = (moved > INK_DIFFERENCE) & (moved >= COVERED * np.maximum(full, 1e-6))
        behind = b[_grow(ink)] if ink.any() else b.reshape(-1, 3)
        shown = alpha * rgb + (1.0 - alpha) * behind
        ratios = contrast_ratio(shown, behind)
        worst = int(np.argmin(ratios))
        out.append(
            Measured(
                mark.kind,
                mark.text,
                (x0, y0, x1, y1),
                float(ratios[worst]),
                tuple(float(c) for c in behind[worst]),
                len(behind),
            )
        )
    return out


def frame_texts(window) -> list:
    """The text of the latest frame drawn into ``window`` (a HeadlessTarget)."""
    return (
        [*window.headless.pipeline.texts, *window.renderer.hud.texts]
        if window.drawn[2].quality is not None
        else list(window.renderer.hud.texts)
    )


def measure_window(window) -> list[Measured]:
    """The latest frame of ``window`` (a HeadlessTarget), measured: it is drawn again without
    its glyphs for the background."""
    hud = window.renderer.hud
    image = window.image.copy()
    texts = frame_texts(window)
    hud.ink = False
    try:
        background = window.redraw()
    finally:
        hud.ink = True
    window.redraw()  # leave the HUD's bookkeeping as the frame drew it
    return measure(image, background, texts)


def worst_by_kind(measured) -> dict[str, Measured]:
    out: dict[str, Measured] = {}
    for m in measured:
        if m.kind not in out or m.ratio < out[m.kind].ratio:
            out[m.kind] = m
    return out


def problems(measured, minimum: float = MINIMUM) -> list[str]:
    """Every element under ``minimum``, one line each, worst first."""
    return [str(m) for m in sorted(measured, key=lambda m: m.ratio) if m.ratio < minimum]
