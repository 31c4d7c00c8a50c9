"""The frame governor: holds the kiosk's frame time at a target by stepping the picture's quality
down, and back up, one level of exhibit.render.quality's ladder at a time. Pure logic on a clock
and the frame times it is given, so it is tested with a fake clock and made-up frame times.

* The target is the display's refresh interval when vsync is on (60 Hz when the display does not
  say), else 1 / display.fps_limit; [quality] target_fps overrides it.
* Frame times are what drawing a frame costs (exhibit.render.frame.FrameTimer: GPU timer
  queries, or on software GL the wall time up to glFinish), never the wait for vsync, so the
  governor sees its headroom.
* It steps down when the median of the last ``window_s`` of frames is above ``down`` x target
  (at once, without waiting for ``step_interval_s``, when it is above ``far`` x target), and up
  when nearly all of them (the 90th percentile) are below ``up`` x target. The window is time,
  not a count of frames: it decides once its frames cover ``window_s`` (a frame covers its own
  duration) and number at least ``min_frames`` (one hitch is never a median); far too slow
  frames decide as soon as there are ``min_frames`` of them. A count of frames within the
  window (5 in 2 s) left a kiosk at 1-3 fps at its level for minutes; now 1 fps steps down
  within about 3.5 s (`exhibit bench governor`). Decisions never
  flicker: at most one step every ``step_interval_s`` (but for far too slow steps down), none
  in the first moments at a new level or scene (their first frames are not typical), none
  while a visitor turns a control quickly (and for ``calm_s`` after), and a step up that had to
  be taken back within two intervals is not tried again for ``backoff_s``, doubling each time
  it fails again (up to an hour).
* [quality] in kiosk.toml pins a whole level, or any of its settings (the governor then only
  moves the others), and can set the lowest level it may go to.

``health()`` is what the health file carries: the level's name and the measured frame time, and
the longest whole frame (poll, update, draw, swap) since start-up, ``frame_ms_max``, counted from
STARTUP_S after the first frame (the first frames compile shaders and fill caches).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from exhibit.render.quality import LADDER, Quality, ladder, software_renderer

if TYPE_CHECKING:  # types only
    from exhibit.geometry.view import ViewState
    from exhibit.kiosk.config import KioskConfig, QualityConfig
    from exhibit.render.target import RenderTarget

log = logging.getLogger("exhibit.kiosk")

#: When the display does not say its refresh rate.
DEFAULT_REFRESH_HZ = 60.0
#: The longest wait before trying a step up again that failed before.
MAX_BACKOFF_S = 3600.0
#: A visitor turning a view faster than this (degrees per second, any of the six angles or the
#: eye's orbit) is "turning a control quickly": no decisions meanwhile.
FAST_DEG_S = 30.0
#: ... or moving the sensor faster than this, in r = 1/distance per second.
FAST_R_S = 0.1
#: Whole frames in the first seconds after the first one are start-up, not hitches.
STARTUP_S = 10.0


@dataclass(frozen=True)
class Settings:
    """How the governor decides (kiosk.toml [quality]; ranges in configs/kiosk.toml)."""

    target_ms: float = 1000.0 / DEFAULT_REFRESH_HZ
    step_interval_s: float = 4.0
    window_s: float = 2.0
    settle_s: float = 0.5
    down: float = 1.1
    up: float = 0.7
    calm_s: float = 1.5
    backoff_s: float = 30.0
    #: Fewest frames in the window for a decision: with the window's time covered, at 1 fps
    #: three frames decide (a step down within seconds), and a single hitch is never the median.
    min_frames: int = 3
    #: Far too slow (the median above this x target): step down without waiting for
    #: step_interval_s, so starting at the best level on a slow machine costs seconds of
    #: 100 ms frames, not half a minute (steps up still wait).
    far: float = 2.0


def percentile(values: Iterable[float], q: float) -> float:
    """The q-th percentile (0..100) by linear interpolation, as numpy's default."""
    ordered = sorted(values)
    if not ordered:
        return math.nan
    pos = (len(ordered) - 1) * q / 100.0
    low = int(math.floor(pos))
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)


def pick(frame_ms: list[float], target_ms: float, down: float = Settings.down) -> int:
    """The level a governor starting at the top settles on, given each level's typical frame
    time: the first (best) one within ``down`` x target, else the last. `exhibit bench kiosk`
    reports it as the level chosen at a size."""
    for i, ms in enumerate(frame_ms):
        if ms <= target_ms * down:
            return i
    return len(frame_ms) - 1


class Governor:
    """Chooses the quality level frame by frame. ``levels``: the ladder (best first); ``start``:
    the level to begin at; ``pinned``: a fixed level (one level, no decisions)."""

    def __init__(
        self,
        levels: tuple[Quality, ...] = LADDER,
        settings: Settings = Settings(),
        now: float = 0.0,
        start: int = 0,
        pinned: bool = False,
    ):
        if not levels:
            raise ValueError("a governor needs at least one level")
        self.levels = tuple(levels)
        self.settings = settings
        self.pinned = pinned or len(self.levels) == 1
        self.index = max(0, min(start, len(self.levels) - 1))
        self._frames: deque[tuple[float, float]] = deque()
        self._changed = now  # last step (or start): the interval counts from here
        self._settled = now + settings.settle_s
        self._calm_until = -math.inf
        self._last_up: tuple[float, int] | None = None  # (when, level stepped up to)
        self._backoff: dict[int, tuple[float, float]] = {}  # level -> (until, current length)
        self._previous: tuple | None = None  # (scene, view, time) of the last observed frame
        #: The latest frame time given (ms) and the recent median, for the health file.
        self.frame_ms: float | None = None
        self.steps = 0
        #: The longest whole frame (ms) after start-up, when (s after the first frame), how many.
        self.frame_ms_max: float | None = None
        self.frame_ms_max_at: float | None = None
        self._first_frame: float | None = None

    @property
    def quality(self) -> Quality:
        return self.levels[self.index]

    # ------------------------------------------------------------------ what happens on screen

    def observe(self, mode: str, scene: str, view: ViewState, now: float) -> None:
        """The frame about to be drawn: a new scene restarts the measurement (its frames cost
        differently), and a visitor turning the view quickly holds decisions back."""
        previous, self._previous = self._previous, (scene, view, now)
        if previous is None:
            return
        last_scene, last_view, then = previous
        if scene != last_scene:
            self._restart(now)
            return
        if mode == "visitor" and now > then and fast(last_view, view, now - then):
            self.busy(now)

    def busy(self, now: float) -> None:
        """A visitor is turning a control quickly: no decision until calm_s after the last."""
        self._calm_until = now + self.settings.calm_s

    def _restart(self, now: float) -> None:
        self._frames.clear()
        self._settled = now + self.settings.settle_s

    # ------------------------------------------------------------------ frame times

    def update(self, frame_ms: float | None, now: float) -> bool:
        """Record one frame's time (ms; None or not finite: no measurement) and maybe step;
        returns whether the level changed."""
        if frame_ms is None or not math.isfinite(frame_ms) or frame_ms < 0:
            return False
        self.frame_ms = frame_ms
        if self.pinned:
            return False
        s = self.settings
        if now < self._settled:
            return False
        self._frames.append((now, frame_ms))
        window = min(s.window_s, s.step_interval_s)
        while len(self._frames) > s.min_frames and self._covered(1) >= window:
            self._frames.popleft()  # the rest still cover the window
        if now < self._calm_until or len(self._frames) < s.min_frames:
            return False
        times = [ms for _, ms in self._frames]
        far = percentile(times, 50) > s.target_ms * s.far and self.index < len(self.levels) - 1
        if not far and (self._covered(0) < window or now - self._changed < s.step_interval_s):
            return False
        if percentile(times, 50) > s.target_ms * s.down and self.index < len(self.levels) - 1:
            if self._last_up is not None and now - self._last_up[0] <= 2 * s.step_interval_s:
                level = self._last_up[1]  # that step up did not hold: wait longer next time
                length = min(self._backoff.get(level, (0.0, s.backoff_s / 2))[1] * 2, MAX_BACKOFF_S)
                self._backoff[level] = (now + length, length)
            self._last_up = None
            return self._step(self.index + 1, now)
        if (
            self.index > 0
            and percentile(times, 90) < s.target_ms * s.up
            and now >= self._backoff.get(self.index - 1, (-math.inf, 0.0))[0]
        ):
            self._last_up = (now, self.index - 1)
            return self._step(self.index - 1, now)
        return False

    def _covered(self, first: int) -> float:
        """Seconds the window's frames from ``first`` on cover: from that frame's start to the
        end of the latest (a frame is given with the time it began)."""
        last, ms = self._frames[-1]
        return last + ms / 1000.0 - self._frames[first][0]

    def _step(self, index: int, now: float) -> bool:
        self.index = index
        self.steps += 1
        self._changed = now
        self._restart(now)
        return True

    def adapt(self, frame_ms: float | None, now: float) -> None:
        """update() after a frame drawn, and a log line when the level changed."""
        if self.update(frame_ms, now):
            log.info(
                "quality %s (frames took %.1f ms, the target is %.1f ms)",
                self.quality.describe(),
                self.recent_ms or 0.0,
                self.settings.target_ms,
            )

    def frame_done(self, frame_ms: float, now: float) -> None:
        """A whole frame's wall time (ms; poll to swap), for the longest since start-up."""
        if self._first_frame is None:
            self._first_frame = now
        if not math.isfinite(frame_ms) or now - self._first_frame < STARTUP_S:
            return
        if self.frame_ms_max is None or frame_ms > self.frame_ms_max:
            self.frame_ms_max = frame_ms
            self.frame_ms_max_at = now - self._first_frame

    @property
    def recent_ms(self) -> float | None:
        """The median frame time of the current window (None before any)."""
        return percentile([ms for _, ms in self._frames], 50) if self._frames else self.frame_ms

    def health(self) -> dict:
        """For the health file: the level's name and settings, the measured frame time and the
        target (ms)."""
        recent = self.recent_ms
        q = self.quality
        return {
            "quality": q.name,
            "quality_detail": {
                "antialiasing": q.antialiasing,
                "mesh": q.mesh,
                "effects": q.effects,
                "render_scale": q.scale,
                "level": self.index + 1,
                "levels": len(self.levels),
                "pinned": self.pinned,
                "steps": self.steps,
            },
            "frame_ms": None if recent is None else round(recent, 2),
            "frame_ms_max": (None if self.frame_ms_max is None else round(self.frame_ms_max, 2)),
            "frame_ms_max_at_s": (
                None if self.frame_ms_max_at is None else round(self.frame_ms_max_at, 1)
            ),
            "target_ms": round(self.settings.target_ms, 2),
        }


def fast(a: ViewState, b: ViewState, dt: float) -> bool:
    """Whether the view moved from a to b in dt seconds faster than a visitor turning a knob
    slowly: any angle (or the eye's orbit) above FAST_DEG_S, or the sensor above FAST_R_S."""
    if dt <= 0:
        return False
    angles = list(zip(a.angles, b.angles)) + [
        (a.eye_azimuth, b.eye_azimuth),
        (a.eye_incidence, b.eye_incidence),
    ]
    turn = max(abs(math.remainder(y - x, 2 * math.pi)) for x, y in angles)
    return math.degrees(turn) / dt > FAST_DEG_S or abs(b.sensor_r - a.sensor_r) / dt > FAST_R_S


# ---------------------------------------------------------------------- the kiosk's governor


def kiosk_levels(
    quality_config: QualityConfig | None, renderer: str
) -> tuple[tuple[Quality, ...], bool]:
    """The ladder for this kiosk: its [quality] pins applied, MSAA and render scales below 1
    left out on software GL (unless pinned), cut at the lowest level allowed. Returns (levels,
    pinned)."""
    q = quality_config
    if q is not None and q.level != "auto":
        base = next(level for level in LADDER if level.name == q.level)
        levels = ladder(q.antialiasing_pin, q.mesh_pin, q.effects_pin, q.scale_pin, levels=(base,))
        return levels, True
    levels = LADDER
    if q is not None and q.lowest != "auto":
        cut = next(i for i, level in enumerate(LADDER) if level.name == q.lowest)
        levels = LADDER[: cut + 1]
    aa = q.antialiasing_pin if q is not None else None
    scale = q.scale_pin if q is not None else None
    if software_renderer(renderer):
        # On software GL a multisample resolve costs a full-screen pass of 4x the samples, and
        # the pass that upscales a smaller picture about what that picture saves (scale-75 is
        # slower than direct: docs/PERFORMANCE.md); the ladder must stay in cost order, so
        # direct is the lowest level there.
        levels = (
            tuple(
                level
                for level in levels
                if (aa is not None or level.antialiasing != "msaa")
                and (scale is not None or level.scale == 1.0)
            )
            or levels
        )
    if q is not None:
        levels = ladder(aa, q.mesh_pin, q.effects_pin, q.scale_pin, levels=levels)
    return levels, len(levels) == 1


def target_ms(config: KioskConfig, refresh_hz: float | None) -> float:
    """The frame time to hold: [quality] target_fps, else the refresh interval with vsync (60 Hz
    when unknown), else 1 / fps_limit."""
    q = config.quality
    if q.target_fps is not None:
        return 1000.0 / q.target_fps
    if config.vsync:
        hz = refresh_hz if refresh_hz and 10 <= refresh_hz <= 1000 else DEFAULT_REFRESH_HZ
        return 1000.0 / hz
    return 1000.0 / config.fps_limit


def for_kiosk(config: KioskConfig, window: RenderTarget, now: float) -> Governor:
    """The governor of a running kiosk, from its config and window (no renderer name counts as
    a GPU, no refresh rate as 60 Hz)."""
    info = window.ctx.info
    renderer = info.get("GL_RENDERER", "") if isinstance(info, dict) else ""
    q = config.quality
    levels, pinned = kiosk_levels(q, renderer)
    settings = Settings(
        target_ms=target_ms(config, window.refresh_hz),
        step_interval_s=q.step_interval_s,
        calm_s=q.calm_s,
        up=q.headroom,
    )
    return Governor(levels, settings, now=now, pinned=pinned)


def mesh_levels(governor: Governor) -> list[int]:
    """The mesh levels the kiosk must load at start-up: those of every level it may use."""
    return sorted({q.mesh for q in governor.levels})
