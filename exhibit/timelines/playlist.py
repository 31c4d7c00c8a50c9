"""The attract playlist: timelines one after another, looping (exhibit.kiosk.state plays it)."""

from __future__ import annotations

from dataclasses import dataclass, field

from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Keyframe, Timeline


@dataclass
class Playlist:
    """Plays timelines one after another, looping; knows where it is at any time."""

    timelines: list[Timeline]
    started: float = 0.0
    _total: float = field(init=False)

    def __post_init__(self) -> None:
        self._total = sum(t.duration for t in self.timelines)

    def restart(self, now: float, index: int = 0) -> None:
        self.started = now - sum(t.duration for t in self.timelines[:index])

    def insert(self, index: int, timeline: Timeline, now: float) -> None:
        """``timeline`` added at ``index`` (the kiosk's, as its scene becomes ready), the one
        playing at ``now`` going on where it is."""
        current, offset = None, 0.0
        if self.timelines and self._total > 0:
            t = (now - self.started) % self._total
            for i, playing in enumerate(self.timelines):
                if t <= playing.duration:
                    current, offset = i, t
                    break
                t -= playing.duration
        self.timelines.insert(index, timeline)
        self._total += timeline.duration
        if current is None:
            self.started = now
        else:
            current += index <= current
            # A µs inside the timeline: at a boundary, rounding in at()'s sums could hand the
            # instant to a neighbour (at() gives a boundary to the timeline before it).
            duration = self.timelines[current].duration
            if duration > 2e-6:
                offset = min(max(offset, 1e-6), duration - 1e-6)
            self.started = now - sum(t.duration for t in self.timelines[:current]) - offset

    def at(self, now: float, stepped: bool = False) -> tuple[Timeline, ViewState, str]:
        """The timeline playing at ``now``, its view and caption (``stepped``: Timeline.at's,
        for reduced motion)."""
        timeline, t = self.locate(now)
        view, caption = timeline.at(t, stepped)
        return timeline, view, caption

    def keyframe_at(self, now: float) -> Keyframe:
        """The keyframe in force at ``now`` (its caption is the one shown)."""
        timeline, t = self.locate(now)
        return timeline.keyframes[timeline.index_at(min(max(t, 0.0), timeline.duration))]

    def hold(self, seconds: float) -> None:
        """Everything from now on ``seconds`` later: the timeline on screen holds where it is
        (narration still speaking: exhibit.kiosk.narrator)."""
        self.started += seconds

    def locate(self, now: float) -> tuple[Timeline, float]:
        """The timeline playing at ``now`` and the time into it."""
        t = (now - self.started) % self._total if self._total > 0 else 0.0
        for timeline in self.timelines:
            if t <= timeline.duration:
                return timeline, t
            t -= timeline.duration
        last = self.timelines[-1]
        return last, last.duration
