"""What is on screen, in the log: a line at each mode or scene change, and the journal fields
EXHIBIT_MODE and EXHIBIT_SCENE set for every record from then on (errors included), so
`journalctl -u exhibit EXHIBIT_SCENE=hopf` finds what happened while a scene was shown."""

from __future__ import annotations

import logging
import math

from exhibit.kiosk.state import Frame, KioskState
from exhibit.operations import journal

log = logging.getLogger("exhibit.kiosk")


class ScreenLog:
    """``changed(mode, scene, frame)`` after each frame; EXHIBIT_MODE is "notice" while there is
    no state (no scene could be prepared)."""

    def __init__(self, state: KioskState | None) -> None:
        self.state = state
        self._fields: dict[str, str | None] = {}
        self.update()

    def update(self) -> dict[str, str | None]:
        """The journal fields for what is on screen, set for every record from now on and
        returned for the record about the change itself."""
        fields: dict[str, str | None]
        if self.state is None:
            fields = {"EXHIBIT_MODE": "notice", "EXHIBIT_SCENE": None}
        else:
            fields = {"EXHIBIT_MODE": self.state.mode, "EXHIBIT_SCENE": self.state.frame.scene}
        if fields != self._fields:
            journal.set_context(**fields)
            self._fields = fields
        return fields

    def changed(self, mode: str, scene: str, frame: Frame) -> None:
        """A line when ``frame`` changed the mode or the scene from ``mode`` and ``scene``."""
        if frame.mode == mode and frame.scene == scene:
            return
        fields = self.update()
        if frame.mode != mode:
            angles = ", ".join(f"{math.degrees(a):.1f}" for a in frame.view.angles)
            log.info(
                "mode %s: scene %s, angles (%s) degrees",
                frame.mode,
                frame.scene,
                angles,
                extra=fields,
            )
        else:
            log.info("scene %s (%s mode)", frame.scene, frame.mode, extra=fields)
