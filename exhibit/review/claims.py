"""Captions proved on the picture: a timeline's ``while`` conditions measured on the frames the
real kiosk draws (`exhibit render --timeline FILE --verify`).

check-config holds a caption to what the timeline file says of the view
(exhibit.timelines.captions). That is not enough: a caption "Now the 4D viewpoint moves closer" was
true of the sensor while the framing zoomed out, so the doughnuts shrank on screen. Here the kiosk
plays the timeline (exhibit.review.player.KioskPlayer: its framing, language, reduced motion) and
every sample of a caption's time on screen is measured as drawn: the view the frame used (its
sensor distance and pose, for the conditions check-config knows) and the object-id pass's pixels
per named object (exhibit.render.passes.ids: never by colour) for the claims about the picture
(visible, absent, grows, shrinks, outgrows, fills).

The claims are units (exhibit.timelines.claims): each kind measures and checks itself on the
samples; :func:`judge` loops over them as the renderer loops over its passes.

A problem is one line ``file: keyframe N: claim: what was measured``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from exhibit.kiosk.config import KioskConfig
from exhibit.render.passes.ids import object_names
from exhibit.review.marks_named import FrameWords, unexplained_problems
from exhibit.review.player import KioskPlayer, caption_spans, play_schedule
from exhibit.review.setup import read_timeline
from exhibit.review.tags_seen import tag_faults, tag_problems
from exhibit.timelines.captions import caption_runs
from exhibit.timelines.claims.base import EVERY_MOMENT, STAGES, Sample, Seen, matching
from exhibit.timelines.model import Condition, Timeline

if TYPE_CHECKING:
    from exhibit.render import Headless

#: Seconds between the samples of a caption (its two ends always among them).
SAMPLE_S = 0.5
#: The first sample is this long after the caption appears (the frame has settled).
SETTLE_S = 0.25
#: A frame in a crossfade whose outgoing picture is more opaque than this shows mostly the
#: picture before: it is not measured (reduced motion's steps, a cut to a new caption).
MOSTLY_BEFORE = 0.5
#: Id frames are measured at this height, in the screen's aspect: shares of the screen are what
#: the claims compare, and they hardly depend on the size.
ID_HEIGHT = 360


@dataclass(frozen=True)
class Run:
    """A caption and when it is on screen (its stating keyframe first), with its condition
    (empty when it states none: its marks and tags are still checked)."""

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


def claim_runs(timeline: Timeline, every: bool = False) -> list[Run]:
    """Each stretch of a timeline whose caption states a condition (``every``: each stretch
    with a caption)."""
    out = []
    for first, t0, t1 in caption_runs(timeline, lambda k: (k.caption_from, k.condition)):
        keyframe = timeline.keyframes[first]
        condition = keyframe.condition
        if condition is None and every and keyframe.caption:
            condition = Condition()
        if condition is not None and t1 > t0:
            out.append(Run(first, t0, t1, condition))
    return out


def count_claims(condition: Condition) -> int:
    """How many claims a condition makes (for reports): each view condition and each named
    object of each picture claim counts once (each kind says: Claim.count)."""
    return sum(claim.count() for claim in condition.claims)


def id_size(size: tuple[int, int]) -> tuple[int, int]:
    """The id frames' size for a screen of ``size``: ID_HEIGHT high (or the screen's height
    when smaller), the screen's aspect."""
    height = min(ID_HEIGHT, size[1])
    return max(1, round(size[0] * height / size[1])), height


def measure(
    player: KioskPlayer, fps: float, runs: list[Run], step: Callable[[int], object] | None = None
) -> tuple[dict[float, Sample], dict[float, FrameWords]]:
    """Play ``player``'s timeline at ``fps`` and measure each run's samples: {t: Sample} (each
    object's pixels as a visitor sees them: in front, and under no part of the HUD) and
    {t: FrameWords} (what the words on screen name, and the tags' faults); ``step(1)`` after
    each frame drawn."""
    times = sorted({t for run in runs for t in run.times()})
    footprinted = {n for run in runs for c in run.condition.claims for n in c.footprints()}
    samples: dict[float, Sample] = {}
    words: dict[float, FrameWords] = {}
    ids = None
    screen = player.config.size
    size = id_size(screen)
    for frame in player.play(fps, times=times, progress=step):
        shown = player.kiosk.shown
        fade = player.kiosk._fade(player.clock())
        if shown is None or fade > MOSTLY_BEFORE:
            continue  # the screen shows mostly the picture before this one
        gpu, view = shown
        hud = player.headless.renderer.hud
        hud.anchors.pace(fps)
        if ids is None:
            ids = player.headless.renderer.ids
            player.headless.activate()
        objects = tuple(object_names(gpu))
        named = {o for n in footprinted for o in matching(n, objects)}
        surfaces = tuple(i for i, s in enumerate(gpu.surfaces) if s.name in named)
        image = ids.image(gpu, view, size)
        covered = hud.cover.mask(screen, size)
        coverage = ids.objects(gpu, view, size, covered=covered, image=image)
        pixels = dict(coverage.pixels)
        whole = ids.objects(gpu, view, size, image=image).pixels
        # a labelled marker's disc is drawn by the HUD: there the HUD is the object, not a cover
        pixels.update({m.name: whole[m.name] for m in gpu.mesh.markers if m.label})
        footprint = ids.footprints(gpu, view, size, surfaces=surfaces) if named else {}
        centres = object_centres(image, covered, objects)
        samples[frame.t] = Sample(
            frame.t, view, pixels, coverage.size, objects, footprint, whole, centres
        )
        panels = hud.layout.panels if hud.layout is not None else []
        tagged = {o for n in hud.tag_objects for o in matching(n, objects)}
        explained = {o for n in getattr(hud, "explained", ()) for o in matching(n, objects)}
        # Mid-crossfade (reduced motion's steps, a cut) the screen blends two pictures and the
        # tags fade with them: they are held to the settled frames.
        faults = () if fade > 0.0 else tag_faults(hud, image, objects, screen, panels)
        words[frame.t] = FrameWords(frozenset(tagged | explained), faults)
    return samples, words


def object_centres(
    image: np.ndarray, covered: np.ndarray, objects: tuple[str, ...]
) -> dict[str, tuple[float, float]]:
    """Per object name, the centre of its pixels in ``image`` that ``covered`` leaves
    visible, as fractions of the frame's width and height (where a description says it is)."""
    height, width = image.shape
    ys, xs = np.indices((height, width))
    keep = ~covered
    ids = image[keep]
    n = len(objects) + 1
    count = np.bincount(ids, minlength=n)
    sx = np.bincount(ids, weights=(np.asarray(xs)[keep] + 0.5) / width, minlength=n)
    sy = np.bincount(ids, weights=(np.asarray(ys)[keep] + 0.5) / height, minlength=n)
    out: dict[str, list[float]] = {}
    for i, name in enumerate(objects):
        if count[i + 1]:
            acc = out.setdefault(name, [0.0, 0.0, 0.0])
            acc[0] += count[i + 1]
            acc[1] += sx[i + 1]
            acc[2] += sy[i + 1]
    return {name: (x / c, y / c) for name, (c, x, y) in out.items()}


@dataclass
class Found:
    """What one play of a timeline contradicts, by check: the captions' claims, the marks no
    word names, the tags' faults (one line each)."""

    claims: list[str] = field(default_factory=list)
    marks: list[str] = field(default_factory=list)
    tags: list[str] = field(default_factory=list)

    def __iadd__(self, other: Found) -> Found:
        self.claims += other.claims
        self.marks += other.marks
        self.tags += other.tags
        return self

    @property
    def lines(self) -> list[str]:
        return self.claims + self.marks + self.tags


def problems(
    timeline: Timeline,
    runs: list[Run],
    samples: dict[float, Sample],
    where: str = "",
    words: dict[float, FrameWords] | None = None,
    stepped: bool = False,
) -> Found:
    """Every claim of ``runs`` the measured ``samples`` contradict, and with ``words`` every
    unexplained mark and tag fault; ``where`` ("en, reduced motion") ends each line;
    ``stepped``: played in reduced motion."""
    found = Found()
    suffix = f" ({where})" if where else ""
    for run in runs:
        mine = [s for s in samples if run.start <= s <= run.end]
        wanted = [min(mine, key=lambda s: abs(s - t)) for t in run.times()] if mine else []
        times = list(dict.fromkeys(wanted))
        seen = [samples[t] for t in times]
        if len(seen) < 1:
            continue
        head = f"{timeline.path}: keyframe {run.first}"
        found.claims += [line + suffix for line in judge(run, seen, head, stepped)]
        if words is None:
            continue
        frames = [words[t] for t in times]
        labels = [name for name, _ in timeline.keyframes[run.first].labels]
        marks = unexplained_problems(run.condition, labels, seen, frames, head)
        found.marks += [line + suffix for line in marks]
        tags = tag_problems(head, times, [f.tag_faults for f in frames])
        found.tags += [line + suffix for line in tags]
    return found


def judge(run: Run, samples: list[Sample], head: str, stepped: bool = False) -> list[str]:
    """Each claim of ``run`` held to the ``samples``, kind by kind as exhibit.timelines.claims
    lists them, stage by stage (the view conditions, what shows at every moment, what changes
    from start to end); a name no object of the scene has is reported once, before the
    picture's checks."""
    claims = run.condition.claims
    objects = samples[0].objects
    named = list(dict.fromkeys(n for claim in claims for n in claim.names()))
    matched = {name: matching(name, objects) for name in named}
    seen = Seen(samples, run.first, f"{head}: while", head, matched, stepped)
    out = []
    for stage in STAGES:
        if stage == EVERY_MOMENT:  # the names, before what shows of them
            out += [
                f"{head}: {name!r}: no object of the scene has that name "
                f"(objects: {', '.join(dict.fromkeys(objects))})"
                for name in named
                if not matched[name]
            ]
        for claim in claims:
            if claim.stage == stage:
                out += claim.problems(seen)
    return out


@dataclass
class Verdict:
    """What verifying one timeline found: its captions, those with claims, the claims checked
    (once per language and motion played), and what failed (:class:`Found`): the claims, the
    marks no word names and the tags' faults."""

    path: str
    captions: int = 0
    captions_with_claims: int = 0
    claims: int = 0
    checked: int = 0
    found: Found = field(default_factory=Found)

    @property
    def problems(self) -> list[str]:
        return self.found.lines

    @property
    def holding(self) -> int:
        return self.checked - len(self.found.claims)


def plays(languages: tuple[str, ...], reduced: tuple[bool, ...]) -> list[tuple[str, bool]]:
    """The plays a verification makes: each language, each motion setting."""
    return [(language, stepped) for language in languages for stepped in reduced]


def frames_to_verify(timeline: Timeline, fps: float, played: int) -> int:
    """How many kiosk frames verifying ``timeline`` draws in ``played`` plays at ``fps`` (each
    caption's samples and the frames a crossfade into each needs), for the job's bound and the
    progress bar."""
    times = sorted({t for run in claim_runs(timeline, every=True) for t in run.times()})
    return played * len(play_schedule(timeline.duration, fps, times)) if times else 0


def verify(
    path: str | Path,
    config: KioskConfig,
    size: tuple[int, int],
    fps: float,
    languages: tuple[str, ...],
    reduced: tuple[bool, ...] = (False, True),
    headless: Headless | None = None,
    progress: Callable[[str], None] | None = None,
    step: Callable[[int], object] | None = None,
) -> Verdict:
    """Play the timeline at ``path`` in each language and each motion setting (``reduced``:
    False, True or both) on ``config``'s kiosk at ``size``, and hold every caption to its
    claims. ``headless`` (exhibit.render.Headless) is shared by the plays when given;
    ``progress`` is told each play, ``step(n)`` each frame drawn (frames_to_verify in all)."""
    timeline = read_timeline(path)
    runs = claim_runs(timeline, every=True)
    verdict = Verdict(str(path))
    verdict.captions = len({s.text for s in caption_spans(timeline)})
    with_claims = {timeline.keyframes[r.first].caption for r in runs if r.condition.claims}
    verdict.captions_with_claims = len(with_claims - {""})
    verdict.claims = sum(count_claims(r.condition) for r in runs)
    if not runs:
        return verdict
    for language, stepped in plays(languages, reduced):
        where = language + (", reduced motion" if stepped else "")
        if progress is not None:
            progress(f"{timeline.path}: {where}")
        played = dataclasses.replace(config, reduced_motion=stepped)
        with KioskPlayer(
            size, timeline=path, language=language, config=played, headless=headless
        ) as player:
            samples, words = measure(player, fps, runs, step)
        verdict.checked += verdict.claims
        verdict.found += problems(timeline, runs, samples, where, words, stepped)
    return verdict
