"""The colours of the marks and words drawn over the picture, shared by the passes that draw
marks (exhibit.render.passes.silhouettes), the HUD (exhibit.render.hud) and its key and labels
(exhibit.render.hud_key, exhibit.render.hud_labels)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

from exhibit.scenes.colours import luminance

#: The live Lemma 2 points' discs (silhouette.glsl's u_pinch) and the key's disc beside its
#: words.
PINCH_COLOR = (1.0, 0.93, 0.2)
#: The dark halo under the HUD's words and marks.
HALO = (0.02, 0.02, 0.03, 0.85)
#: The HUD's words.
INK = (0.96, 0.96, 0.93, 1.0)


def darker(color: tuple[float, float, float], factor: float = 0.32) -> tuple[float, float, float]:
    """A surface's outline ink: its colour, darker."""
    r, g, b = color
    return (float(r) * factor, float(g) * factor, float(b) * factor)


#: The relative luminance (WCAG) every coloured word is lifted to: 7:1 (AAA) against the panel
#: over white (0.12 grey, luminance 0.014) needs 0.40; this leaves a margin.
LEGIBLE = 0.45


def legible(rgb: Sequence[float], minimum: float = LEGIBLE) -> tuple[float, float, float]:
    """``rgb`` mixed toward white just enough to reach the luminance ``minimum`` (itself when
    it does): the same hue, light enough for text on the HUD's dark panels."""
    # (r, g, b): the casts only tell the type checker the length it cannot count.
    rgb = cast("tuple[float, float, float]", tuple(float(c) for c in rgb[:3]))
    if luminance(rgb) >= minimum:
        return rgb
    lo, hi = 0.0, 1.0
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        if luminance([c + mid * (1.0 - c) for c in rgb]) >= minimum:
            hi = mid
        else:
            lo = mid
    return cast("tuple[float, float, float]", tuple(c + hi * (1.0 - c) for c in rgb))
