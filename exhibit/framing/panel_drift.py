"""Where the text panels sit: a slow Lissajous path within drift_px, so no pixel shows the same
bright text for months (burn-in care); still with reduced motion, where the crossfaded pose
changes do that work."""

from __future__ import annotations

import math
from typing import Protocol


class DriftConfig(Protocol):
    """What the drift reads of the kiosk's config (exhibit.kiosk.config.KioskConfig)."""

    @property
    def reduced_motion(self) -> bool: ...

    @property
    def drift_period_s(self) -> float: ...

    @property
    def drift_px(self) -> float: ...


class PanelDrift:
    """``drift(now)`` -> the panels' offset in pixels, ``started`` being the path's origin."""

    def __init__(self, config: DriftConfig, started: float) -> None:
        self.config = config
        self.started = started

    def __call__(self, now: float) -> tuple[float, float]:
        if self.config.reduced_motion:
            return (0.0, 0.0)
        phase = 2 * math.pi * (now - self.started) / self.config.drift_period_s
        amplitude = self.config.drift_px / 2
        return (amplitude * (1 + math.sin(phase)), amplitude * (1 + math.sin(0.71 * phase + 1.3)))
