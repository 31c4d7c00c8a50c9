"""Framing for one screen: the HUD layout's free area (exhibit.render.layout) and the fit of the
projected mesh into it (exhibit.geometry.framing), for scene start views, figure presets and
"home" (attract timelines: exhibit.framing.timeline_framing, on this). No GL: the kiosk frames
at start-up, `exhibit render` before it draws, and the tests check the result on the CPU.

A scene's start view and each of its presets are framed unless the scene or preset says
``fit = False`` (Figure 8, whose point is that the torus fills the world).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

from exhibit.geometry.framing import Sample, frame, mesh_sample
from exhibit.geometry.view import ViewState
from exhibit.render.layout import Rect, TextSizes, free_rectangles, hud_layout

if TYPE_CHECKING:
    from exhibit.scenes.base import Scene
    from exhibit.surfaces.mesh import Mesh4D

#: Captions a picture is kept clear of: each a tuple of paragraphs (caption, note).
Captions = Sequence[tuple[str, ...]]


def _as_shown(text: str) -> tuple[str, ...]:
    return (text,)


class Framer:
    """Frames views for a screen of ``size`` with the kiosk's text ``sizes`` and burn-in
    ``drift`` (pixels the panels may move); ``hud=False``: no panels, the whole screen (inside
    the margin) is free. ``versions(text)`` gives every way a text may be shown (the kiosk:
    one per language), and the picture is kept clear of the panels of them all, so a visitor
    who changes the language never finds the longer German caption over the surface."""

    def __init__(
        self,
        size: tuple[int, int],
        sizes: TextSizes = TextSizes(),
        drift: float = 0.0,
        hud: bool = True,
        extra: tuple[Rect, ...] = (),
        versions: Callable[[str], tuple[str, ...]] = _as_shown,
        words: tuple[tuple[tuple[str, str], ...], ...] = ((),),
    ):
        self.size = (int(size[0]), int(size[1]))
        self.sizes = sizes
        self.drift = float(drift)
        self.hud = hud
        #: Panels beyond the HUD's (the time-slice inset, exhibit.render.inset).
        self.extra = tuple(extra)
        self.versions = versions
        #: The numbers panel's words (HudInfo.words) in each version, in the same order.
        self.words = tuple(words) or ((),)

    def panels(self, title: str, captions: Captions) -> list[Rect]:
        """Every panel the HUD may draw with ``title`` and any one of ``captions`` (each a
        tuple of paragraphs: caption, note), in every version of the words."""
        out: list[Rect] = list(self.extra)
        if not self.hud:
            return out
        titles = self.versions(title)  # one per language, "" included
        for paragraphs in captions or [("",)]:
            shown = [self.versions(p) for p in paragraphs]
            for i, heading in enumerate(titles):
                words = tuple(p[i] if i < len(p) else p[0] for p in shown)
                hud_words = self.words[i] if i < len(self.words) else self.words[0]
                out += hud_layout(
                    self.size, heading, words, self.sizes, self.drift, hud_words
                ).panels
        return out

    def areas(self, title: str, captions: Captions) -> list[Rect]:
        """The free area: the largest rectangles clear of every panel by the layout's margin."""
        layout = hud_layout(self.size, title, ("",), self.sizes, self.drift)
        return free_rectangles(self.size, self.panels(title, captions), layout.margin)

    def view(
        self,
        mesh: Mesh4D,
        view: ViewState,
        title: str,
        captions: Captions,
        poses: Iterable[ViewState] = (),
        points: Sample | None = None,
    ) -> ViewState:
        """``view`` zoomed and shifted so ``mesh`` (at ``view`` and every pose of ``poses``)
        lies in the free area."""
        if points is None:
            points = mesh_sample(mesh)
        return frame(view, points, self.size, self.areas(title, captions), poses)

    def scene_view(
        self,
        scene: Scene,
        mesh: Mesh4D,
        view: ViewState | None = None,
        note: str = "",
        fit: bool = True,
        points: Sample | None = None,
    ) -> ViewState:
        """A scene's start view (or ``view``, e.g. a preset's, or a visitor's pose), framed
        for the scene's own title and caption unless the scene or the caller opts out;
        ``points``: the mesh's sample, when the caller keeps it."""
        view = scene.view if view is None else view
        if not (fit and scene.fit):
            return view
        return self.view(mesh, view, scene.title, [(scene.caption, note)], points=points)
