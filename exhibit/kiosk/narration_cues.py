"""Where the kiosk's frames meet its narration: what is on screen spoken once while narration is
on, and attract mode held at the end of a caption's window while its words go on (within a
timeline, and at its end: the next timeline, or the same one looping, would cut them off)."""

from __future__ import annotations

from exhibit.devices.base import Event
from exhibit.kiosk.language import Translator
from exhibit.kiosk.narrator import Narrator
from exhibit.kiosk.state import ATTRACT, Frame, KioskState


class NarrationCues:
    """Called once a frame: listen() and hold() before the state steps, speak() after.
    ``translate`` says the language on screen."""

    def __init__(self, narrator: Narrator, translate: Translator) -> None:
        self.narrator = narrator
        self.translate = translate
        #: Where attract mode was at the last frame: (timeline path, time into it, when).
        self._at: tuple[str, float, float] | None = None

    def listen(self, state: KioskState, events: list[Event], now: float) -> list[Event]:
        """A listen press turns narration on or off; the events less it (no takeover). Both
        the press and narration the visitor asked for, while it speaks, are presence: the idle
        return counts from the end of the words, not from the last turn (a visitor who cannot
        see the screen presses listen, then listens)."""
        if state.mapper.pressed(events, "listen"):
            self.narrator.press()
            state.present(now)
        if self.narrator.pressed_on and self.narrator.speaking:
            state.present(now)
        return state.mapper.without(events, "listen")

    def hold(self, state: KioskState, now: float) -> None:
        """Attract mode waits while the words of the caption it is leaving go on."""
        last, self._at = self._at, None
        if state.mode != ATTRACT or not self.narrator.on(True):
            return
        playlist = state.playlist
        if not playlist.timelines:
            return
        timeline, t = playlist.locate(now)
        until = self.narrator.speaking_until(self.translate.language)
        if until is not None:
            path, end = until
            if timeline.path == path and t > end and (last is None or last[1] <= t):
                playlist.hold(t - end)
            elif last is not None and last[0] == path and last[1] <= end + 1e-6:
                moved_on = timeline.path != path or t < last[1]
                if moved_on:  # past the end since the last frame: back to just before it
                    playlist.hold((now - last[2]) - (end - last[1]))
            timeline, t = playlist.locate(now)
        self._at = (timeline.path, t, now)

    def speak(self, state: KioskState, frame: Frame, now: float) -> None:
        """What is on screen, spoken once, while narration is on."""
        attract = frame.mode == ATTRACT
        if not self.narrator.on(attract):
            return
        language = self.translate.language
        if attract and state.playlist.timelines:
            timeline, t = state.playlist.locate(now)
            self.narrator.speak_timeline(timeline, t, language, now)
        elif not attract:
            self.narrator.speak_scene(frame.scene, frame.title, frame.caption, language, now)
