"""A player that plays onto tape: what a review of the kiosk (`exhibit render --timeline FILE
--narration`) hears, on the review's own clock, and when.

The kiosk's player (exhibit.narration.player) plays in real time on a sound card; a review runs
the kiosk on a fake clock, much slower or faster than real time, and wants the sound as a track
beside its frames. This player has the same interface: ``playing`` is true until the sound's
length has passed on ``clock``; a sound stopped early is cut where it stopped."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # sound.py is imported where a tape is mixed down
    from exhibit.narration.sound import Sound


@dataclass
class Take:
    """One sound on the tape: when it started and ended on the clock."""

    start: float
    end: float
    sound: object


class TapePlayer:
    def __init__(self, clock: Callable[[], float]):
        self.clock = clock
        self.takes: list[Take] = []

    def play(self, sound: Sound) -> None:
        self.stop()
        now = self.clock()
        self.takes.append(Take(now, now + float(sound.duration), sound))

    def stop(self) -> None:
        now = self.clock()
        if self.takes and self.takes[-1].end > now:
            self.takes[-1].end = now

    @property
    def playing(self) -> bool:
        return bool(self.takes) and self.clock() < self.takes[-1].end

    def status(self) -> dict:
        return {"state": "ok", "device": "tape", "error": None}

    def close(self) -> None:
        self.stop()

    def mixdown(self, duration: float) -> Sound:
        """The tape as one sound of ``duration`` seconds (exhibit.narration.sound.mix), each take
        cut where it was stopped."""
        from exhibit.narration.sound import RATE, Sound, mix

        placed = []
        for take in self.takes:
            keep = max(0, round((take.end - take.start) * RATE))
            placed.append((take.start, Sound(take.sound.samples[:keep])))  # type: ignore[attr-defined]
        return mix(placed, duration)
