"""What a kiosk frame costs, pass by pass, for the health file: now and then one frame is
measured (exhibit.render.pass_timer: on software GL a glFinish at each pass boundary, which
costs that frame some overlap, so only one frame in SAMPLE_S seconds pays it), and the latest
measurement is reported with the quality level it was drawn at and its age."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from exhibit.render.pass_timer import PassTimes
from exhibit.render.target import RenderTarget

#: Seconds between measured frames.
SAMPLE_S = 10.0


class PassSampler:
    """Asks the window to measure a frame every ``every_s`` seconds; ``health`` reports the
    newest measured one. ``level`` names the quality level frames are drawn at now."""

    def __init__(
        self, window: RenderTarget, level: Callable[[], str], every_s: float = SAMPLE_S
    ) -> None:
        self.window, self.level, self.every_s = window, level, every_s
        self._asked_at: float | None = None
        self._asked_level = ""
        self._seen: PassTimes | None = None
        self._measured: tuple[PassTimes, str, float] | None = None

    def health(self, now: float) -> dict[str, Any] | None:
        """The health file's ``frame_passes`` (None before the first measured frame); asks for
        the next measurement when one is due."""
        latest = self.window.pass_times
        if latest is not None and latest is not self._seen and self._asked_at is not None:
            self._seen = latest
            self._measured = (latest, self._asked_level, self._asked_at)
        if self._asked_at is None or now - self._asked_at >= self.every_s:
            self.window.measure_passes()
            self._asked_at, self._asked_level = now, self.level()
        if self._measured is None:
            return None
        times, level, at = self._measured
        return {
            "level": level,
            "mode": times.mode,
            "age_s": round(max(0.0, now - at), 1),
            "total_ms": round(times.total_ms, 2),
            "passes_ms": {name: round(ms, 2) for name, ms in times.passes.items()},
            "other_ms": round(times.other_ms, 2),
        }
