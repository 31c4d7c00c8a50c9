"""Start-up work the first frames would otherwise pay for, done one piece per frame after the
first: every title and caption panel laid out and rasterised, and a frame drawn through a
crossfade at every quality level the governor may choose (software GL compiles each shader
variant at its first draw, and the crossfade's snapshot is allocated at the first cut: each a
long frame at the first scene change otherwise)."""

from __future__ import annotations

import dataclasses
import functools
import logging
from collections.abc import Callable, Iterable

from exhibit import scenes
from exhibit.kiosk.assembly import KioskParts
from exhibit.kiosk.content import nearest_level
from exhibit.render.frame_request import FrameRequest
from exhibit.render.options import RenderOptions
from exhibit.render.quality import Quality
from exhibit.render.renderer import HudInfo
from exhibit.render.target import RenderTarget

log = logging.getLogger("exhibit.kiosk")


class WarmUp:
    """Chores in order; each returns whether it is done (False: try again next frame, e.g.
    while a crossfade holds the snapshot a quality level would draw through)."""

    def __init__(self, chores: Iterable[Callable[[], bool]] = ()):
        self.chores = list(chores)

    def __bool__(self) -> bool:
        return bool(self.chores)

    def step(self) -> None:
        """One piece (never fatal: the frames do it themselves when needed)."""
        chore = self.chores[0]
        try:
            if not chore():
                return
        except Exception as exc:  # noqa: BLE001
            log.warning("start-up warm-up step failed: %s", exc)
        self.chores.pop(0)

    def all(self) -> None:
        """Every piece left, now (a kiosk that prepares everything before its first frame:
        reviews, tests)."""
        while self.chores:
            self.chores.pop(0)()


class Chores:
    """A kiosk's warm-up chores, from its ``parts`` (none when there is no state: the notice
    screen needs no warming). ``fading()``: whether a crossfade is under way (its snapshot is
    in use: a quality level waits); ``hud``: whether the kiosk shows text panels at all."""

    def __init__(
        self, parts: KioskParts, window: RenderTarget, hud: bool, fading: Callable[[], bool]
    ) -> None:
        self.state, self.content, self.words = parts.state, parts.content, parts.words
        self.text, self.levels = parts.text, parts.governor.levels
        self.languages = parts.translate.order
        self.window, self.hud, self.fading = window, hud, fading

    def all(self) -> list:
        """Every title and caption panel in every language, then a frame at every quality
        level the governor may choose."""
        if self.state is None:
            return []
        known = set(scenes.names())
        timelines = self.content.timelines
        names = (set(self.state.content) | {t.scene for t in timelines}) & known
        words = {(scenes.get(name).title, scenes.get(name).caption, name) for name in names}
        words |= {
            (scenes.get(t.scene).title, k.caption, t.scene)
            for t in timelines
            for k in t.keyframes
            if t.scene in known
        }
        chores: list = []
        if self.hud:
            chores += [
                functools.partial(self.panel, self.words(title, caption, scene, language))
                for language in self.languages
                for title, caption, scene in sorted(words)
            ]
        return chores + [functools.partial(self.quality, quality) for quality in self.levels]

    def panel(self, hud: HudInfo) -> bool:
        self.window.warm_hud([hud], self.text)
        return True

    def quality(self, quality: Quality) -> bool:
        """A frame at ``quality`` through a crossfade into the back buffer (the next frame
        draws over it); waits while a crossfade is under way (its snapshot is in use)."""
        if self.fading() or self.state is None:
            return False
        frame = self.state.frame
        levels = self.content.levels((frame.scene, frame.params))
        if not levels:
            return False
        options = RenderOptions(hud=self.hud, quality=quality, text=self.text)
        gpu = nearest_level(levels, quality.mesh)
        hud = self.words(frame.title, frame.caption, frame.scene, tags=frame.tags)
        request = FrameRequest(gpu, frame.view, options, hud)
        self.window.capture(request)
        self.window.draw(dataclasses.replace(request, fade=0.5))
        return True
