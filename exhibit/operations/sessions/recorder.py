"""The frame loop's side of the session log: the session under way kept in memory (a few list
appends a frame), handed to the writer when the visitor leaves; never raises, never blocks."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable

from exhibit.devices.base import Event
from exhibit.operations.sessions.config import SessionsConfig
from exhibit.operations.sessions.session import Session, input_name
from exhibit.operations.sessions.writer import SessionWriter

log = logging.getLogger("exhibit.operations.sessions")


class SessionLog:
    """What the kiosk calls, on the frame thread: cheap, never raises, never blocks.

    ``observe(mode, scene, events, now)`` once a frame does it all; ``started``, ``scene``,
    ``input`` and ``ended`` are the steps, for callers that know the transitions. ``now`` is the
    kiosk's monotonic clock (lengths are differences of it, immune to clock steps); the wall
    clock dates the session. ``language`` is the language on screen (the kiosk sets it as it
    changes: exhibit.kiosk.language).
    """

    def __init__(
        self,
        writer: SessionWriter | None,
        wall: Callable[[], float] = time.time,
        language: str = "en",
    ):
        self.writer = writer
        self.wall = wall
        self.language = language
        self.current: Session | None = None
        self._start = self._last_input = 0.0
        self._broken = False

    def health(self) -> dict:
        """For the health file: what the writer has done (sessions written, dropped because it
        was behind, refused by the database) and the language on screen."""
        w = self.writer
        counts = (
            {
                "written": w.written,
                "dropped": w.dropped,
                "failed": w.failed,
                "waiting": len(w.backlog),
            }
            if w
            else {}
        )
        # What the writer really does: recording only once the database is open and while it
        # stays usable; otherwise false, with the reason the log gave.
        reason = None
        if w is None:
            reason = "no writer"
        elif self._broken:
            reason = "the recorder failed (see the log)"
        elif not w.ready.is_set():
            reason = "opening the database"
        elif not w.usable:
            reason = w.reason or "the database cannot be written"
        state: dict[str, int | str] = {**counts, "recording": reason is None}
        if reason is not None:
            state["reason"] = reason
        if w is not None and w.errno is not None:
            state["errno"] = w.errno  # the health file's storage errors
        return {"sessions": state, "language": self.language}

    # -- the steps

    def started(self, now: float, scene: str) -> None:
        wall = self.wall()
        offset = int(time.localtime(wall).tm_gmtoff) if math.isfinite(wall) else 0
        self.current = Session(
            start=wall,
            end=wall,
            duration_s=0.0,
            active_s=0.0,
            utc_offset_s=offset,
            language=self.language,
        )
        self._start = self._last_input = now
        self.scene(scene)

    def scene(self, name: str) -> None:
        if self.current is not None and name not in self.current.scenes:
            self.current.scenes.append(name)

    def input(self, name: str, now: float | None = None) -> None:
        if self.current is None:
            return
        if name not in self.current.inputs:
            self.current.inputs.append(name)
        if now is not None and now > self._last_input:
            self._last_input = now

    def inputs(self, events: Iterable[Event], now: float) -> None:
        for event in events:
            name = input_name(event)
            if name is not None:
                self.input(name, now)

    def ended(self, now: float) -> Session | None:
        """End the session (if one is open) and hand it to the writer; returns it."""
        session, self.current = self.current, None
        if session is None:
            return None
        session.duration_s = max(0.0, now - self._start)
        session.active_s = min(session.duration_s, max(0.0, self._last_input - self._start))
        session.end = session.start + session.duration_s
        session.language = self.language
        if self.writer is not None:
            self.writer.submit(session)
        return session

    # -- once a frame

    def observe(self, mode: str, scene: str, events: Iterable[Event], now: float) -> None:
        """Follow the kiosk: a visitor frame starts a session or continues it (the scene and
        the inputs used), an attract frame ends the open one. A bug here is logged once and
        turns recording off: it must never make a frame fail."""
        if self._broken:
            return
        try:
            if mode == "visitor":
                if self.current is None:
                    self.started(now, scene)
                else:
                    self.scene(scene)
                self.inputs(events, now)
            elif self.current is not None:
                self.ended(now)
        except Exception:  # noqa: BLE001 - statistics are never worth a frame
            self._broken = True
            log.exception(
                "sessions: the recorder failed; visitor sessions are no longer "
                "recorded until the kiosk restarts"
            )

    def close(self, now: float, timeout: float = 5.0) -> None:
        """End an open session (the kiosk is stopping) and let the writer finish."""
        try:
            if self.current is not None:
                self.ended(now)
        finally:
            if self.writer is not None:
                self.writer.close(timeout)


def open_session_log(config: SessionsConfig) -> SessionLog | None:
    """The kiosk's recorder for ``[sessions]``, or None when it is disabled. Never raises: the
    database is opened on the writer thread, which logs any problem."""
    if not config.enabled:
        return None
    writer = SessionWriter(config.resolved(), config.keep_days, config.max_sessions)
    return SessionLog(writer)
