"""Captions that stay true: play a timeline and report where a caption is shown while the view
contradicts what it says, or too briefly to be read.

A caption such as "At distance 2 the viewpoint touches the 4D ball" is true only while the sensor
is there; once the timeline moves on, the words must change with it. A keyframe states what its
caption claims in ``while`` (see :mod:`exhibit.timelines.file`): the sensor's distance or motion,
or a pose the view must stay near ("in the plane ..." is true only while the view is the plane
view); this module samples the timeline every ``STEP_S`` seconds and holds each caption to it.

`exhibit check-config` runs it over the attract timelines and reports ``file: key: reason``. The
kiosk itself does not refuse a timeline for it: a wrong caption is the curator's to fix, not a
reason to show a visitor nothing.
"""

from __future__ import annotations

import bisect
import dataclasses
import math

from collections.abc import Callable, Sequence

from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Condition, Keyframe, Timeline

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
#: Slack on r = 1/d when comparing: rounding, not content.
EPS_R = 1e-9


def caption_problems(timeline: Timeline) -> list[str]:
    """Every place in ``timeline`` where a caption is shown outside its ``while`` condition or
    for less than its reading time, as ``file: keyframe[i].key: reason`` lines."""
    return _reading_problems(timeline) + _condition_problems(timeline)


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
        times = _samples(t0, t1, step)
        views = [pose(t) for t in times]
        r = [view.sensor_r for view in views]
        where = f"{timeline.path}: keyframe[{first}].while"
        if condition.sensor_r is not None:
            out += distance_problems(where, condition, times, r)
        if condition.motion is not None:
            out += motion_problems(where, condition.motion, times, r)
        if condition.angles_within is not None:
            out += turn_problems(where, condition, times, views, first)
    return out


#: The pose's eight angles, as check-config names them.
POSE_NAMES = ("θ1", "θ2", "θ3", "θ4", "θ5", "θ6", "eye azimuth", "eye incidence")


def turn_problems(
    where: str, condition: Condition, times: list[float], views: Sequence[ViewState], first: int
) -> list[str]:
    """The pose turned more than ``angles_within`` degrees from the stating keyframe's."""
    limit, stated = condition.angles_within, condition.pose
    assert limit is not None and stated is not None  # set together (WhileSpec.condition)
    turns = []  # per sample: (largest turn in degrees, which angle)
    for view in views:
        pose = view.angles + (view.eye_azimuth, view.eye_incidence)
        diffs = [abs(math.degrees(a - b)) for a, b in zip(pose, stated)]
        k = max(range(len(diffs)), key=diffs.__getitem__)
        turns.append((diffs[k], k))
    bad = [j for j, (turn, _) in enumerate(turns) if turn > limit + 1e-6]
    if not bad:
        return []
    worst, k = max(turns[j] for j in bad)
    return [
        f"{where}.angles_within: the caption is shown at t = {time_spans(times, bad)} with the "
        f"view turned up to {worst:.1f}° ({POSE_NAMES[k]}) from keyframe[{first}]'s pose, "
        f"more than {limit:g}°"
    ]


def _distance(r: float) -> str:
    return "inf" if r <= 0 else f"{1 / r:.3g}"


def distance_problems(
    where: str, condition: Condition, times: list[float], r: list[float]
) -> list[str]:
    assert condition.sensor_r is not None and condition.sensor_distance is not None  # together
    low, high = condition.sensor_r
    bad = [j for j, x in enumerate(r) if not low - EPS_R <= x <= high + EPS_R]
    if not bad:
        return []
    d = condition.sensor_distance
    want = (
        "inf" if d[0] == math.inf else f"[{d[0]:g}, {'inf' if d[1] == math.inf else f'{d[1]:g}'}]"
    )
    near, far = _distance(max(r[j] for j in bad)), _distance(min(r[j] for j in bad))
    seen = near if near == far else f"{near}..{far}"
    return [
        f"{where}.sensor_distance: the caption is shown at t = {time_spans(times, bad)} with the "
        f"sensor at {seen}, outside {want}"
    ]


def motion_problems(where: str, motion: str, times: list[float], r: list[float]) -> list[str]:
    steps = [b - a for a, b in zip(r, r[1:])]
    sign = {"closer": 1.0, "farther": -1.0, "still": 0.0}[motion]
    if sign == 0.0:
        bad = [j for j, s in enumerate(steps) if abs(s) > EPS_R]
        what = "the sensor moves"
    else:
        bad = [j for j, s in enumerate(steps) if s * sign < -EPS_R]
        what = "the sensor moves " + ("farther" if sign > 0 else "closer")
        if not bad and not any(s * sign > EPS_R for s in steps):
            return [
                f"{where}.sensor_motion: the caption says the sensor moves {motion}, but it "
                f"stays at {_distance(r[0])} all the while (t = {times[0]:g}..{times[-1]:g} s)"
            ]
    if not bad:
        return []
    return [
        f"{where}.sensor_motion: the caption says {motion!r}, but {what} at t = "
        f"{time_spans(times, bad, steps=True)}"
    ]


def time_spans(times: list[float], indices: list[int], steps: bool = False, most: int = 3) -> str:
    """Sample indices (with ``steps``: the steps from sample j to j + 1) as time ranges:
    "28.0..36.0 s" or "1.0..2.0 s, 5.0 s"."""
    spans: list[list[int]] = []
    for j in indices:
        if spans and j == spans[-1][1] + 1:
            spans[-1][1] = j
        else:
            spans.append([j, j])
    parts = []
    for a, b in spans[:most]:
        start, end = times[a], times[b + 1] if steps else times[b]
        parts.append(f"{start:.1f} s" if end == start else f"{start:.1f}..{end:.1f} s")
    return ", ".join(parts) + (f" and {len(spans) - most} more" if len(spans) > most else "")
