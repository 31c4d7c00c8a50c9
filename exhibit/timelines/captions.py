"""Captions that stay true: play a timeline and report where a caption is shown while the view
contradicts what it says, or too briefly to be read.

A caption such as "At distance 2 the viewpoint touches the 4D ball" is true only while the sensor
is there; once the timeline moves on, the words must change with it. A keyframe states what its
caption claims in ``while`` (see :mod:`exhibit.timelines.file`): the sensor's distance or motion,
or a pose the view must stay near ("in the plane ..." is true only while the view is the plane
view); this module samples the timeline every ``STEP_S`` seconds and holds each caption to the
claims of those kinds (exhibit.timelines.claims: ``on_file``), each kind's own check.

`exhibit check-config` runs it over the attract timelines and reports ``file: key: reason``. The
kiosk itself does not refuse a timeline for it: a wrong caption is the curator's to fix, not a
reason to show a visitor nothing.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence

from exhibit.geometry.view import ViewState
from exhibit.timelines.claims.base import Sample, Seen
from exhibit.timelines.model import Keyframe, Timeline
from exhibit.timelines.object_names import known, unknown_line

#: Sampling step (s): a tenth of the shortest stretch anyone would write between keyframes.
STEP_S = 0.05
#: Samples for a whole timeline: past it the step grows (a caption held for hours, thousands of
#: captions), so check-config stays quick whatever the timeline's length. Each caption's two
#: ends are always sampled.
MAX_SAMPLES = 20_000
#: Reading time: 0.4 s a word (150 words a minute: slower than a seated reader, because a visitor
#: also watches the picture), and never under 3 s. A caption shown for less is lost.
SECONDS_PER_WORD = 0.4
MIN_READ_S = 3.0


def caption_problems(timeline: Timeline) -> list[str]:
    """Every place in ``timeline`` where a caption is shown outside its ``while`` condition or
    for less than its reading time, as ``file: keyframe[i].key: reason`` lines."""
    return _reading_problems(timeline) + _condition_problems(timeline)


def name_problems(
    timeline: Timeline, objects: Sequence[str], aliases: Mapping[str, str]
) -> list[str]:
    """Every label and claim of ``timeline`` naming no object of its scene (``objects``, the
    scene's Scene.objects; ``aliases`` only for the line, the timeline has them resolved), at
    the keyframe that writes it: ``file: keyframe N: labels: no object "NAME"; objects are
    ...`` or ``... keyframe N: while.KEY: ...``."""
    out: list[str] = []
    previous: Keyframe | None = None
    for i, frame in enumerate(timeline.keyframes):
        head = f"{timeline.path}: keyframe {i}"
        # carried over from the keyframe before: the same objects, reported where written
        if previous is None or frame.labels is not previous.labels:
            for name in dict.fromkeys(name for name, _ in frame.labels):
                if not known(name, objects):
                    out.append(unknown_line(f"{head}: labels", name, objects, aliases))
        condition = frame.condition
        if condition is not None and (previous is None or condition is not previous.condition):
            for claim in condition.claims:
                for name in dict.fromkeys(claim.names()):
                    if not known(name, objects):
                        where = f"{head}: while.{claim.key}"
                        out.append(unknown_line(where, name, objects, aliases))
        previous = frame
    return out


def reading_time(caption: str) -> float:
    """Seconds a visitor needs to read ``caption`` (0 for no caption)."""
    words = len(caption.split())
    return 0.0 if not words else max(MIN_READ_S, SECONDS_PER_WORD * words)


def caption_runs(
    timeline: Timeline, key: Callable[[Keyframe], object]
) -> list[tuple[int, float, float]]:
    """(first keyframe index, start t, end t) of each run of keyframes with the same ``key``."""
    frames = timeline.keyframes
    runs: list[tuple[int, float, float]] = []
    start = 0
    for i in range(1, len(frames) + 1):
        if i == len(frames) or key(frames[i]) != key(frames[start]):
            end = frames[i].t if i < len(frames) else timeline.duration
            runs.append((start, frames[start].t, end))
            start = i
    return runs


def _reading_problems(timeline: Timeline) -> list[str]:
    out = []
    for first, t0, t1 in caption_runs(timeline, lambda k: k.caption):
        caption = timeline.keyframes[first].caption
        need = reading_time(caption)
        if t1 - t0 < need:
            where = "the timeline ends here" if t1 == t0 else f"t = {t0:g}..{t1:g} s"
            out.append(
                f"{timeline.path}: keyframe[{first}].caption: shown for {t1 - t0:.1f} s "
                f"({where}), too short to read: {len(caption.split())} words need "
                f"{need:.1f} s ({SECONDS_PER_WORD:g} s a word, at least {MIN_READ_S:g} s)"
            )
    return out


def _samples(t0: float, t1: float, step: float = STEP_S) -> list[float]:
    """Every ``step`` from t0 to t1, both ends included."""
    n = max(1, math.ceil((t1 - t0) / step))
    return [t0 + (t1 - t0) * j / n for j in range(n + 1)]


class _Poses:
    """``timeline.at(t)[0]`` played on the two keyframes around ``t`` (the same view), so a
    sample does not scan every keyframe of a long timeline."""

    def __init__(self, timeline: Timeline):
        self.timeline = timeline
        self.times = [k.t for k in timeline.keyframes]

    def __call__(self, t: float) -> ViewState:
        frames = self.timeline.keyframes
        t = min(max(t, 0.0), self.timeline.duration)
        i = max(0, bisect.bisect_right(self.times, t) - 1)
        return dataclasses.replace(self.timeline, keyframes=frames[i : i + 2]).at(t)[0]


def _condition_problems(timeline: Timeline) -> list[str]:
    out = []
    runs = [
        (first, t0, t1)
        for first, t0, t1 in caption_runs(timeline, lambda k: (k.caption_from, k.condition))
        if timeline.keyframes[first].condition is not None
    ]
    # one step for the whole timeline: STEP_S, or coarser where that would pass MAX_SAMPLES
    step = max(STEP_S, sum(t1 - t0 for _, t0, t1 in runs) / MAX_SAMPLES)
    pose = _Poses(timeline)
    for first, t0, t1 in runs:
        condition = timeline.keyframes[first].condition
        assert condition is not None  # runs keeps the keyframes with one
        samples = [Sample(t, pose(t)) for t in _samples(t0, t1, step)]
        seen = Seen(samples, first, f"{timeline.path}: keyframe[{first}].while")
        for claim in condition.claims:
            if claim.on_file:  # the view conditions: the picture is --verify's to measure
                out += claim.problems(seen)
    return out
