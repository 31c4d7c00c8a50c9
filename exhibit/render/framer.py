"""Framing for one screen: the HUD layout's free area (exhibit.render.layout) and the fit of the
projected mesh into it (exhibit.geometry.framing), for scene start views, figure presets, "home"
and whole attract timelines. No GL: the kiosk frames at start-up, `exhibit render` before it
draws, and the tests check the result on the CPU.

What is framed, and what is not:

* a scene's start view and each of its presets, unless the scene or preset says ``fit = False``
  (Figure 8, whose point is that the torus fills the world);
* an attract timeline, as a whole: one zoom and lens shift that keep the picture in the free
  area at every keyframe and at samples between them (a zoom per keyframe would make the
  picture breathe), clear of the largest of its captions. A timeline that sets ``half_height``
  itself is framed by hand by its curator and left alone, unless it says ``fit = true`` (its
  zooms are then replaced); ``fit = false`` leaves any timeline alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from exhibit.geometry.framing import frame, mesh_points
from exhibit.geometry.view import ViewState
from exhibit.render.layout import Rect, TextSizes, free_rectangles, hud_layout

#: Seconds between the poses sampled along a timeline (keyframes are always sampled).
TIMELINE_STEP_S = 0.5
#: Points of a mesh used to frame a timeline (dozens of poses): its bounds to a pixel or so.
TIMELINE_POINTS = 4000


class Framer:
    """Frames views for a screen of ``size`` with the kiosk's text ``sizes`` and burn-in
    ``drift`` (pixels the panels may move); ``hud=False``: no panels, the whole screen (inside
    the margin) is free."""

    def __init__(self, size: tuple[int, int], sizes: TextSizes = TextSizes(),
                 drift: float = 0.0, hud: bool = True):
        self.size = (int(size[0]), int(size[1]))
        self.sizes = sizes
        self.drift = float(drift)
        self.hud = hud

    def panels(self, title: str, captions) -> list[Rect]:
        """Every panel the HUD may draw with ``title`` and any one of ``captions`` (each a
        tuple of paragraphs: caption, note)."""
        out: list[Rect] = []
        if not self.hud:
            return out
        for paragraphs in captions or [("",)]:
            out += hud_layout(self.size, title, tuple(paragraphs), self.sizes,
                              self.drift).panels
        return out

    def areas(self, title: str, captions) -> list[Rect]:
        """The free area: the largest rectangles clear of every panel by the layout's margin."""
        layout = hud_layout(self.size, title, ("",), self.sizes, self.drift)
        return free_rectangles(self.size, self.panels(title, captions), layout.margin)

    def view(self, mesh, view: ViewState, title: str, captions, poses=(),
             points: np.ndarray | None = None) -> ViewState:
        """``view`` zoomed and shifted so ``mesh`` (at ``view`` and every pose of ``poses``)
        lies in the free area."""
        if points is None:
            points = mesh_points(mesh)
        return frame(view, points, self.size, self.areas(title, captions), poses)

    def scene_view(self, scene, mesh, view: ViewState | None = None, note: str = "",
                   fit: bool = True) -> ViewState:
        """A scene's start view (or ``view``, e.g. a preset's), framed unless the scene or the
        caller opts out."""
        view = scene.view if view is None else view
        if not (fit and scene.fit):
            return view
        return self.view(mesh, view, scene.title, [(scene.caption, note)])

    def timeline(self, timeline, scene, mesh):
        """The timeline with one zoom and shift for all of it (see the module docstring), or
        the timeline itself when it sets its own zoom or its scene or preset opts out."""
        base = timeline.base_view
        presets = [p for p in scene.presets if p.view == base]
        wanted = getattr(timeline, "fit", None)
        if wanted is False or not scene.fit or any(not p.fit for p in presets):
            return timeline
        if wanted is None and any(k.half_height != base.half_height
                                  for k in timeline.keyframes):
            return timeline
        times = sorted({*np.arange(0.0, timeline.duration, TIMELINE_STEP_S).tolist(),
                        *(k.t for k in timeline.keyframes)})
        poses = [timeline.at(t)[0] for t in times]
        captions = [(c,) for c in dict.fromkeys(k.caption for k in timeline.keyframes)]
        framed = self.view(mesh, base, scene.title, captions, poses,
                           points=mesh_points(mesh, TIMELINE_POINTS))
        keyframes = tuple(dataclasses.replace(k, half_height=framed.half_height)
                          for k in timeline.keyframes)
        return dataclasses.replace(timeline, base_view=framed, keyframes=keyframes)
