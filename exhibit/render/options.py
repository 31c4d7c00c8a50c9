"""What the renderer draws, beyond the ViewState: toggles a kiosk, the CLI or a test can set."""

from __future__ import annotations

from dataclasses import dataclass, replace

from exhibit.render.layout import TextSizes
from exhibit.render.quality import Quality

#: Dark blue-grey gradient: the tori's greens and reds read well on it and it does not glare.
BACKGROUND = ((0.16, 0.18, 0.23), (0.03, 0.035, 0.05))


@dataclass(frozen=True)
class RenderOptions:
    #: Live 4D -> 2D silhouette curves (Lemma 3) on every surface.
    silhouettes: bool = True
    #: Mark the points where the projected normal vanishes (Lemma 2).
    pinch_points: bool = True
    #: Colour surfaces by their 4D depth (view w) instead of their material.
    depth_colour: bool = False
    #: Solid surfaces (off: only their silhouettes, curves and markers, unoccluded by them).
    surfaces: bool = True
    #: Intersection curves of the 3D image: where sheets of the projected surfaces cross, inked
    #: as a crisp curve (kiosk frames and Headless.frame; the direct path has no sheet buffer).
    intersections: bool = True
    #: Width in px (at 720 px) of the intersection curves' core (at most 1 px: the pass looks
    #: one pixel around each pixel), plus a 1 px antialiased rim.
    intersection_width: float = 1.0
    #: Curves, wire meshes and markers.
    curves: bool = True
    #: Title, caption, angles, sensor distance, axes gizmo, marker labels.
    hud: bool = True
    #: Background gradient (top, bottom) as RGB in [0, 1].
    background: tuple[tuple[float, float, float], tuple[float, float, float]] = BACKGROUND
    #: Line widths are given for a 720-pixel-high picture and scale with the height; None = auto.
    line_scale: float | None = None
    #: Width in px (at 720 px) of the live silhouette curves and diameter of Lemma 2 marks.
    silhouette_width: float = 2.5
    pinch_size: float = 9.0
    #: Factor on the width of curves, wire meshes and markers (the kiosk's lean effects < 1).
    curve_width: float = 1.0
    #: Shift of the text panels in pixels (x right, y down): the kiosk moves them slowly so no
    #: overlay burns into the screen.
    hud_drift: tuple[float, float] = (0.0, 0.0)
    #: A quality level (exhibit.render.quality) for a window to draw a whole kiosk frame at
    #: (offscreen scene, FXAA or MSAA, render scale); None: the direct path.
    quality: Quality | None = None
    #: Text sizes as fractions of the screen height, and when a distance reads ∞
    #: (exhibit.render.layout.TextSizes; the kiosk's [text] table).
    text: TextSizes = TextSizes()

    def at_quality(self, quality: Quality) -> RenderOptions:
        """These options at a quality level: a "lean" level drops the intersection curves (their
        sheet buffer and passes are its whole saving); everything else stays."""
        return self if quality.intersections else replace(self, intersections=False)

    def width_scale(self, height: int) -> float:
        if self.line_scale is not None:
            return self.line_scale
        return max(height / 720.0, 0.5)
