"""What a visitor's coming and going changes besides the picture, once a frame: the language on
screen (a press switches it, attract mode cycles it, the idle return resets it), the session log
(exhibit.operations.sessions: its visitor's language kept current as it changes), and
narration turned off when the visitor walks away."""

from __future__ import annotations

from exhibit.devices.base import Event
from exhibit.kiosk.language import LanguageChoice, Translator
from exhibit.kiosk.narrator import Narrator
from exhibit.kiosk.state import ATTRACT, Frame, KioskState
from exhibit.operations.sessions import SessionLog


class Visits:
    """``after(state, mode, frame, events, now, sessions)`` once a frame, after the state
    stepped from ``mode`` to ``frame``; ``sessions`` is the kiosk's recorder, or None."""

    def __init__(self, language: LanguageChoice, translate: Translator, narrator: Narrator) -> None:
        self.language, self.translate, self.narrator = language, translate, narrator

    def after(
        self,
        state: KioskState,
        mode: str,
        frame: Frame,
        events: list[Event],
        now: float,
        sessions: SessionLog | None,
    ) -> None:
        self.language.update(state.mapper.pressed(events, "language"), state.mode == ATTRACT, now)
        if sessions is not None:  # never raises, never blocks
            sessions.language = self.translate.language
            sessions.observe(frame.mode, frame.scene, events, now)
        if frame.mode == ATTRACT and mode != ATTRACT:  # after the session took its language
            self.language.walked_away(now)
            if sessions is not None:
                sessions.language = self.translate.language
            self.narrator.walked_away()
