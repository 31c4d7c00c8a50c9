"""Frames that raised, and frame times between two reports: what the kiosk's loop counts so a
bug in one frame is logged without flooding the journal, and the health file gets its numbers."""

from __future__ import annotations

import logging
import math
import traceback
from dataclasses import dataclass, field

log = logging.getLogger("exhibit.kiosk")

#: Failed frames after the first of their kind are summed up in one line at most this often.
ERROR_REPORT_S = 10.0


@dataclass
class FrameStats:
    """Frame times since the last report, for the STATUS line and the health file."""

    times: list[float] = field(default_factory=list)
    gl_errors: int = 0
    slow_frames: int = 0

    def gl_error(self, error: str) -> None:
        """The GL error state after a frame: an error is counted, and logged the 1st, 2nd,
        4th, 8th... time (a few lines, even over months)."""
        if error == "GL_NO_ERROR":
            return
        self.gl_errors += 1
        n = self.gl_errors
        if n & (n - 1) == 0:
            log.error("GL error: %s (%d so far)", error, n)

    def slow(self, ms: float, scene: str | None) -> None:
        """A frame over the kiosk's limit: counted, and logged as GL errors are."""
        self.slow_frames += 1
        n = self.slow_frames
        if n & (n - 1) == 0:
            log.warning("slow frame: %.0f ms (scene %s; %d so far)", ms, scene, n)


class FrameErrors:
    """Frames that raised. The first of each kind (exception type and the line that raised it)
    is logged with its traceback, again at most hourly; the others are counted and summed up in
    one line at most every ``every`` seconds, so a frame failing 60 times a second does not
    flood the journal. ``failing_since``: when the current run of failed frames began."""

    def __init__(self, every: float = ERROR_REPORT_S):
        self.every = every
        self.total = 0
        self.failing_since: float | None = None
        self._kinds: dict[tuple, float] = {}  # kind -> when its traceback was last logged
        self._count, self._latest, self._logged = 0, "", -math.inf

    def failed(self, exc: BaseException, now: float) -> None:
        self.total += 1
        if self.failing_since is None:
            self.failing_since = now
        where = traceback.extract_tb(exc.__traceback__)[-1:]
        kind = (type(exc).__name__, *[(w.filename, w.lineno) for w in where])
        if now - self._kinds.get(kind, -math.inf) >= 3600 and len(self._kinds) < 100:
            self._kinds[kind] = self._logged = now
            log.error("a frame failed (the next one tries again)", exc_info=exc)
        else:
            self._count += 1
            self._latest = f"{type(exc).__name__}: {exc}"
        self.flush(now)

    def drawn(self, now: float) -> None:
        self.failing_since = None
        self.flush(now)

    def flush(self, now: float) -> None:
        if self._count and now - self._logged >= self.every:
            log.error(
                "%d more failed frames in the last %.0f s (the last: %s)",
                self._count,
                now - self._logged,
                self._latest,
            )
            self._count, self._logged = 0, now
