"""Captions proved on the picture: a timeline's ``while`` conditions measured on the frames the
real kiosk draws (`exhibit render --timeline FILE --verify`).

check-config holds a caption to what the timeline file says of the view
(exhibit.timelines.captions). That is not enough: a caption "Now the 4D viewpoint moves closer" was
true of the sensor while the framing zoomed out, so the doughnuts shrank on screen. Here the kiosk
plays the timeline (exhibit.review.player.KioskPlayer: its framing, language, reduced motion) and
every sample of a caption's time on screen is measured as drawn: the view the frame used (its
sensor distance and pose, for the conditions check-config knows) and the object-id pass's pixels
per named object (exhibit.render.passes.ids: never by colour) for the claims about the picture
(visible, grows, shrinks, outgrows, fills; exhibit.timelines.model.PictureClaims).

A problem is one line ``file: keyframe N: claim: what was measured``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit.geometry.view import ViewState
from exhibit.kiosk.config import KioskConfig
from exhibit.review.player import KioskPlayer, caption_spans
from exhibit.review.setup import read_timeline
from exhibit.render.passes.ids import ObjectCoverage, object_names
from exhibit.timelines.captions import (
    distance_problems,
    motion_problems,
    caption_runs,
    time_spans,
    turn_problems,
)
from exhibit.timelines.model import Condition, PictureClaims, Timeline

if TYPE_CHECKING:
    from exhibit.render import Headless

#: Seconds between the samples of a caption (its two ends always among them).
SAMPLE_S = 0.5
#: The first sample is this long after the caption appears (the frame has settled).
SETTLE_S = 0.25
#: Id frames are measured at this height, in the screen's aspect: shares of the screen are what
#: the claims compare, and they hardly depend on the size.
ID_HEIGHT = 360
#: "visible": at least this share of the screen (a 2 px curve 140 px long at 1280x720).
VISIBLE_SHARE = 3e-4
#: ... and at least this part of it, against the object drawn with nothing in front of it
#: (a curve hidden inside a tube but for a sliver is not visible).
VISIBLE_PART = 0.3
#: ... unless what shows covers this much of the screen anyway (a big surface mostly behind
#: another is still plainly there).
PLAINLY_VISIBLE = 3e-3
#: "absent": at most this share of the screen (a few pixels of a mark at its first instant).
ABSENT_SHARE = 2e-5
#: "grows" / "shrinks": the area at the caption's end against its start, at least x GROWTH
#: (at most / GROWTH); "outgrows": the first's growth at least OUTGROWTH x the second's.
GROWTH = 1.25
OUTGROWTH = 1.5


@dataclass(frozen=True)
class Sample:
    """One measured moment: the view the frame was drawn with and its objects' pixels."""

    t: float
    view: ViewState
    coverage: ObjectCoverage
    #: the scene's objects in id order (names a claim may match)
    objects: tuple[str, ...]
    #: pixels of the objects that "visible" claims name with nothing in front of them
    footprint: dict[str, int]


@dataclass(frozen=True)
class Run:
    """A caption with a condition and when it is on screen (its stating keyframe first)."""

    first: int
    start: float
    end: float
    condition: Condition

    def times(self) -> list[float]:
        """Where this caption is sampled: SETTLE_S after it appears (half its time when
        shorter), then about every SAMPLE_S, to just before it goes."""
        t0 = self.start + min(SETTLE_S, 0.5 * (self.end - self.start))
        t1 = max(t0, self.end - 1e-3)
        n = max(1, math.ceil((t1 - t0) / SAMPLE_S))
        return [t0 + (t1 - t0) * j / n for j in range(n + 1)]


def claim_runs(timeline: Timeline) -> list[Run]:
    """Each stretch of a timeline whose caption states a condition."""
    out = []
    for first, t0, t1 in caption_runs(timeline, lambda k: (k.caption_from, k.condition)):
        condition = timeline.keyframes[first].condition
        if condition is not None and t1 > t0:
            out.append(Run(first, t0, t1, condition))
    return out


def count_claims(condition: Condition) -> int:
    """How many claims a condition makes (for reports): each view condition and each named
    object of each picture claim counts once."""
    views = sum(
        x is not None for x in (condition.sensor_r, condition.motion, condition.angles_within)
    )
    p = condition.picture
    if p is None:
        return views
    named = len(p.visible) + len(p.absent) + len(p.grows) + len(p.shrinks) + len(p.fills)
    return views + named + bool(p.outgrows)


def id_size(size: tuple[int, int]) -> tuple[int, int]:
    """The id frames' size for a screen of ``size``: ID_HEIGHT high (or the screen's height
    when smaller), the screen's aspect."""
    height = min(ID_HEIGHT, size[1])
    return max(1, round(size[0] * height / size[1])), height


def measure(player: KioskPlayer, fps: float, runs: list[Run]) -> dict[float, Sample]:
    """Play ``player``'s timeline at ``fps`` and measure each run's samples: {t: Sample}."""
    times = sorted({t for run in runs for t in run.times()})
    visible = {n for run in runs if run.condition.picture for n in run.condition.picture.visible}
    samples: dict[float, Sample] = {}
    ids = None
    size = id_size(player.config.size)
    for frame in player.play(fps, times=times):
        shown = player.kiosk.shown
        if shown is None:
            continue
        gpu, view = shown
        if ids is None:
            ids = player.headless.renderer.ids
            player.headless.activate()
        objects = tuple(object_names(gpu))
        named = {o for n in visible for o in _matching(n, objects)}
        surfaces = tuple(i for i, s in enumerate(gpu.surfaces) if s.name in named)
        coverage = ids.objects(gpu, view, size)
        footprint = ids.footprints(gpu, view, size, surfaces=surfaces) if named else {}
        samples[frame.t] = Sample(frame.t, view, coverage, objects, footprint)
    return samples


def problems(
    timeline: Timeline, runs: list[Run], samples: dict[float, Sample], where: str = ""
) -> list[str]:
    """Every claim of ``runs`` the measured ``samples`` contradict; ``where`` ("en, reduced
    motion") ends each line."""
    out = []
    suffix = f" ({where})" if where else ""
    for run in runs:
        wanted = [min(samples, key=lambda s: abs(s - t)) for t in run.times()] if samples else []
        seen = [samples[t] for t in dict.fromkeys(wanted)]
        if len(seen) < 1:
            continue
        head = f"{timeline.path}: keyframe {run.first}"
        lines = _view_problems(run, seen, head) + _picture_problems(run, seen, head)
        out += [line + suffix for line in lines]
    return out


def _view_problems(run: Run, seen: list[Sample], head: str) -> list[str]:
    """check-config's view conditions, on the views the frames were drawn with (reduced
    motion's held steps included)."""
    c = run.condition
    times = [s.t for s in seen]
    r = [s.view.sensor_r for s in seen]
    where = f"{head}: while"
    out = []
    if c.sensor_r is not None:
        out += distance_problems(where, c, times, r)
    if c.motion is not None and len(seen) > 1:
        out += motion_problems(where, c.motion, times, r)
    if c.angles_within is not None:
        out += turn_problems(where, c, times, [s.view for s in seen], run.first)
    return out


def _matching(name: str, objects: tuple[str, ...]) -> list[str]:
    """The objects a claim's ``name`` stands for: that name, or every name it begins."""
    return [o for o in dict.fromkeys(objects) if o == name or o.startswith(name)]


def _area(sample: Sample, names: list[str]) -> int:
    return sum(sample.coverage.pixels.get(n, 0) for n in names)


def _picture_problems(run: Run, seen: list[Sample], head: str) -> list[str]:
    claims: PictureClaims | None = run.condition.picture
    if claims is None:
        return []
    out = []
    objects = seen[0].objects
    matched: dict[str, list[str]] = {}
    for name in claims.names():
        found = _matching(name, objects)
        if not found:
            out.append(
                f"{head}: {name!r}: no object of the scene has that name "
                f"(objects: {', '.join(dict.fromkeys(objects))})"
            )
        matched[name] = found
    total = seen[0].coverage.size[0] * seen[0].coverage.size[1]
    times = [s.t for s in seen]

    def share(name: str, s: Sample) -> float:
        return _area(s, matched[name]) / total

    def least_share(name: str, s: Sample) -> float:
        """VISIBLE_SHARE, or less for an object that is small as a whole (a marker)."""
        whole = sum(s.footprint.get(n, 0) for n in matched[name]) / total
        return min(VISIBLE_SHARE, VISIBLE_PART * whole) if whole else VISIBLE_SHARE

    def shown_part(name: str, s: Sample) -> float:
        """What shows of it against its footprint (a live mark has none: all of it shows)."""
        whole = sum(s.footprint.get(n, 0) for n in matched[name])
        area = _area(s, matched[name])
        return area / whole if whole else float(area > 0)

    for name in claims.visible:
        if not matched[name]:
            continue
        bad = [j for j, s in enumerate(seen) if share(name, s) < least_share(name, s)]
        if bad:
            least = min(share(name, seen[j]) for j in bad)
            out.append(
                f"{head}: visible {name}: covers {100 * least:.3f} % of the screen at t = "
                f"{time_spans(times, bad)}, less than {100 * VISIBLE_SHARE:.2f} % (or, for a small "
                f"object, {100 * VISIBLE_PART:.0f} % of it)"
            )
            continue
        hidden = [
            j
            for j, s in enumerate(seen)
            if shown_part(name, s) < VISIBLE_PART and share(name, s) < PLAINLY_VISIBLE
        ]
        if hidden:
            least = min(shown_part(name, seen[j]) for j in hidden)
            out.append(
                f"{head}: visible {name}: {100 * least:.0f} % of it shows at t = "
                f"{time_spans(times, hidden)} (the rest is behind other objects), less than "
                f"{100 * VISIBLE_PART:.0f} % and under {100 * PLAINLY_VISIBLE:.1f} % of the screen"
            )
    for name in claims.absent:
        if not matched[name]:
            continue
        bad = [j for j, s in enumerate(seen) if share(name, s) > ABSENT_SHARE]
        if bad:
            most = max(share(name, seen[j]) for j in bad)
            out.append(
                f"{head}: absent {name}: covers {100 * most:.3f} % of the screen at t = "
                f"{time_spans(times, bad)}, more than {100 * ABSENT_SHARE:.3f} %"
            )
    for name, low in claims.fills:
        if not matched[name]:
            continue
        bad = [j for j, s in enumerate(seen) if share(name, s) < low]
        if bad:
            least = min(share(name, seen[j]) for j in bad)
            out.append(
                f"{head}: fills {name} = {low:g}: covers {least:.2f} of the screen at t = "
                f"{time_spans(times, bad)}"
            )
    growth: dict[str, float] = {}
    for name in {*claims.grows, *claims.shrinks, *(claims.outgrows or ())}:
        a, b = _area(seen[0], matched[name]), _area(seen[-1], matched[name])
        growth[name] = (b / a) if a else (math.inf if b else 1.0)
    span = f"t = {seen[0].t:.1f}..{seen[-1].t:.1f} s"
    for name, sign in [(n, 1) for n in claims.grows] + [(n, -1) for n in claims.shrinks]:
        if not matched[name] or len(seen) < 2:
            continue
        g = growth[name]
        ok = g >= GROWTH if sign > 0 else g <= 1 / GROWTH
        if not ok:
            a, b = _area(seen[0], matched[name]), _area(seen[-1], matched[name])
            want = f"x{GROWTH:g} or more" if sign > 0 else f"x{1 / GROWTH:.2f} or less"
            out.append(
                f"{head}: {'grows' if sign > 0 else 'shrinks'} {name}: its area on screen went "
                f"from {a} to {b} px (x{g:.2f}, {span}), not {want}"
            )
    if claims.outgrows is not None and len(seen) >= 2:
        first, second = claims.outgrows
        if matched[first] and matched[second]:
            g1, g2 = growth[first], growth[second]
            if not (g1 >= GROWTH and g1 >= OUTGROWTH * g2):
                out.append(
                    f"{head}: outgrows {first}, {second}: grew x{g1:.2f} against x{g2:.2f} "
                    f"({span}), not x{GROWTH:g} or more and {OUTGROWTH:g} times as much"
                )
    return out


@dataclass
class Verdict:
    """What verifying one timeline found: its captions, those with claims, the claims checked
    (once per language and motion played) and the problems."""

    path: str
    captions: int = 0
    captions_with_claims: int = 0
    claims: int = 0
    checked: int = 0
    problems: list[str] = field(default_factory=list)

    @property
    def holding(self) -> int:
        return self.checked - len(self.problems)


def verify(
    path: str | Path,
    config: KioskConfig,
    size: tuple[int, int],
    fps: float,
    languages: tuple[str, ...],
    reduced: tuple[bool, ...] = (False, True),
    headless: Headless | None = None,
    progress: Callable[[str], None] | None = None,
) -> Verdict:
    """Play the timeline at ``path`` in each language and each motion setting (``reduced``:
    False, True or both) on ``config``'s kiosk at ``size``, and hold every caption to its
    claims. ``headless`` (exhibit.render.Headless) is shared by the plays when given."""
    timeline = read_timeline(path)
    runs = claim_runs(timeline)
    verdict = Verdict(str(path))
    verdict.captions = len({s.text for s in caption_spans(timeline)})
    with_claims = {timeline.keyframes[r.first].caption for r in runs}
    verdict.captions_with_claims = len(with_claims - {""})
    verdict.claims = sum(count_claims(r.condition) for r in runs)
    if not runs:
        return verdict
    for language in languages:
        for stepped in reduced:
            where = language + (", reduced motion" if stepped else "")
            if progress is not None:
                progress(f"{timeline.path}: {where}")
            played = dataclasses.replace(config, reduced_motion=stepped)
            with KioskPlayer(
                size, timeline=path, language=language, config=played, headless=headless
            ) as player:
                samples = measure(player, fps, runs)
            verdict.checked += verdict.claims
            verdict.problems += problems(timeline, runs, samples, where)
    return verdict
