"""What every claim kind is (:class:`Claim`), what it is measured on (:class:`Sample`, gathered
into :class:`Seen` for one caption) and the helpers the kinds share.

A kind is one module of this package: its ``while`` key and the schema fragment that reads it,
what it makes of the value (a frozen dataclass, the claim), how many claims it counts for, and
its check with its message. exhibit.timelines.claims lists the kinds in the order their keys are
read; check-config (exhibit.timelines.captions) holds a caption to the kinds it can check on the
timeline file's poses, `--verify` (exhibit.review.claims) to all of them on the frames drawn.
Pure: no GL, no files."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Annotated, Any, ClassVar, Self

from pydantic import Field

from exhibit.geometry.view import ViewState
from exhibit.schema.types import Name

#: Objects one picture claim may name.
MAX_CLAIMED = 16
#: A picture claim's objects: names (or the start of names) of the scene's objects.
Names = Annotated[list[Name], Field(min_length=1, max_length=MAX_CLAIMED)]

#: When a kind is judged, in this order, the kinds of one stage in the registry's order: the
#: view conditions (check-config's too), then what shows at every moment, then what changes
#: from the caption's start to its end. The scene's objects a caption names are looked up
#: between the first two (an unknown name is reported once, before the picture's checks).
VIEW, EVERY_MOMENT, START_TO_END = 0, 1, 2
STAGES = (VIEW, EVERY_MOMENT, START_TO_END)

# The tolerances every kind uses, in one place, each with its reason.
#: Slack on r = 1/d when comparing: rounding, not content.
EPS_R = 1e-9
#: "grows" / "shrinks" / "outgrows": the area at the caption's end against its start, at least
#: x GROWTH (at most / GROWTH).
GROWTH = 1.25
#: "grows" / "shrinks" hold sample by sample too: the area never falls this far below the
#: largest it has been so far in the caption (never rises this far above the smallest). Pixel
#: edges and the mesh's facets move a count by about 1 % as the view turns; 3 % is a shrink a
#: visitor could see.
GROWTH_DIP = 0.03
#: "sensor_motion" closer or farther, played smoothly: the sensor stands still (or moves the
#: other way) for at most this share of the caption's time. A caption may come up a moment
#: before the motion starts; one that stays on seconds after it stops says what is no longer
#: so.
MOTION_STILL_SHARE = 0.2
#: ... played in reduced motion (held steps: exhibit.timelines.model.STEP_S), no still stretch
#: longer than a held step and the gap between two samples.
MOTION_STILL_STEPPED_S = 4.5


@dataclass(frozen=True)
class Sample:
    """One moment of a caption: the view (as the timeline file has it, or as a frame was drawn
    with it) and, for a frame, its objects' pixels in the object-id pass
    (exhibit.render.passes.ids: never by colour)."""

    t: float
    view: ViewState
    #: per object name, the pixels where it is in front and no part of the HUD covers it (a
    #: panel, a tag, a word: exhibit.render.hud_cover): what a visitor sees of it
    pixels: Mapping[str, int] = field(default_factory=dict)
    #: the id frame's size (width, height)
    size: tuple[int, int] = (0, 0)
    #: the scene's objects in id order (names a claim may match)
    objects: tuple[str, ...] = ()
    #: pixels of the objects a claim asks footprints of with nothing in front of them
    footprint: Mapping[str, int] = field(default_factory=dict)
    #: per object name, the pixels where it is in front, under the HUD too (what growth is
    #: measured on: a tag moving over an object does not shrink it); empty: as ``pixels``
    drawn: Mapping[str, int] = field(default_factory=dict)
    #: per object name, the centre of its pixels as seen, as fractions of the screen's width
    #: and height from its top-left corner (where a description says it is)
    centres: Mapping[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class Seen:
    """A caption's samples, how a problem names it, and the objects each claimed name stands
    for (check-config's samples have no objects)."""

    samples: Sequence[Sample]
    #: the keyframe that states the condition
    first: int
    #: the view conditions' lines start with it ("file: keyframe[3].while" for check-config,
    #: "file: keyframe 3: while" for --verify)
    where: str
    #: the picture claims' lines start with it ("file: keyframe 3")
    head: str = ""
    matched: Mapping[str, Sequence[str]] = field(default_factory=dict)
    #: played in reduced motion: the pose moves in held steps
    stepped: bool = False

    @property
    def times(self) -> list[float]:
        return [s.t for s in self.samples]

    @property
    def r(self) -> list[float]:
        """The sensor's r = 1/d at each sample."""
        return [s.view.sensor_r for s in self.samples]

    def area(self, name: str, sample: Sample) -> int:
        """Pixels of the objects ``name`` stands for in ``sample``."""
        return sum(sample.pixels.get(n, 0) for n in self.matched[name])

    def share(self, name: str, sample: Sample) -> float:
        """The share of the screen they cover."""
        size = self.samples[0].size
        return self.area(name, sample) / (size[0] * size[1])

    def centre(self, name: str, sample: Sample) -> tuple[float, float] | None:
        """The centre of what shows of the objects ``name`` stands for, weighted by their
        pixels (None when none shows)."""
        parts = [
            (sample.pixels.get(n, 0), sample.centres[n])
            for n in self.matched[name]
            if sample.pixels.get(n, 0) and n in sample.centres
        ]
        total = sum(w for w, _ in parts)
        if not total:
            return None
        return (
            sum(w * c[0] for w, c in parts) / total,
            sum(w * c[1] for w, c in parts) / total,
        )

    def size(self, name: str, sample: Sample) -> int:
        """Pixels of the objects ``name`` stands for in front, whatever of the HUD lies over
        them (Sample.drawn): how big they are drawn, for growth."""
        drawn = sample.drawn or sample.pixels
        return sum(drawn.get(n, 0) for n in self.matched[name])

    def growth(self, name: str) -> float:
        """Their size at the caption's end against its start (inf from nothing, 1 for none)."""
        a, b = self.size(name, self.samples[0]), self.size(name, self.samples[-1])
        return (b / a) if a else (math.inf if b else 1.0)

    @property
    def span(self) -> str:
        return f"t = {self.samples[0].t:.1f}..{self.samples[-1].t:.1f} s"


class Claim:
    """A kind of claim a caption makes in ``while``: a subclass, a frozen dataclass, in a module
    of its own, listed in exhibit.timelines.claims.KINDS."""

    #: its key in ``while``
    key: ClassVar[str]
    #: the schema fragment its value is read with (pydantic; None when not given)
    fragment: ClassVar[Any]
    #: when it is judged (VIEW, EVERY_MOMENT, START_TO_END)
    stage: ClassVar[int]
    #: check-config holds a caption to it on the timeline file's poses (a view condition);
    #: otherwise only --verify can, on the frames
    on_file: ClassVar[bool] = False
    #: how docs/KIOSK.md writes it (a test holds the document to the kinds)
    example: ClassVar[str]

    @classmethod
    def parse(cls, value: Any, pose: tuple[float, ...]) -> Claim:
        """The claim from its validated value; ``pose``: the stating keyframe's angles and eye
        (radians)."""
        raise NotImplementedError

    def count(self) -> int:
        """How many claims it makes, for reports (each named object counts once)."""
        return 1

    def names(self) -> tuple[str, ...]:
        """The objects it names, in order."""
        return ()

    def footprints(self) -> tuple[str, ...]:
        """The objects whose footprint (drawn with nothing in front) it needs measured."""
        return ()

    def problems(self, seen: Seen) -> list[str]:
        """One line per way ``seen`` contradicts it."""
        raise NotImplementedError


@dataclass(frozen=True)
class ObjectsClaim(Claim):
    """A claim about a list of named objects, each counted once (visible, absent, grows,
    shrinks): the list is the claim."""

    fragment: ClassVar[Any] = Names | None

    objects: tuple[str, ...]

    @classmethod
    def parse(cls, value: list[str], pose: tuple[float, ...]) -> Self:
        return cls(tuple(value))

    def count(self) -> int:
        return len(self.objects)

    def names(self) -> tuple[str, ...]:
        return self.objects


def growth_problems(
    seen: Seen, objects: Sequence[str], key: str, sign: int, wanted: str
) -> list[str]:
    """For grows (``sign`` 1) and shrinks (-1): one line per object whose area on screen does
    not change as claimed, from the caption's first sample to its last (by GROWTH; ``wanted``
    says the bound, "x1.25 or more") or on the way (a dip of more than GROWTH_DIP below the
    largest area so far: a peak that falls back before the caption ends)."""
    out = []
    first, last = seen.samples[0], seen.samples[-1]
    for name in objects:
        if not seen.matched[name] or len(seen.samples) < 2:
            continue
        g = seen.growth(name)
        if not (g >= GROWTH if sign > 0 else g <= 1.0 / GROWTH):
            a, b = seen.size(name, first), seen.size(name, last)
            out.append(
                f"{seen.head}: {key} {name}: its area on screen went from {a} to {b} px "
                f"(x{g:.2f}, {seen.span}), not {wanted}"
            )
            continue
        areas = [sign * seen.size(name, s) for s in seen.samples]
        best, back = areas[0], []
        for j, x in enumerate(areas):
            best = max(best, x)
            if x < best - GROWTH_DIP * abs(best):
                back.append(j)
        if back:
            peak = max(areas[: back[0] + 1]) * sign
            low = areas[back[0]] * sign
            turn = "shrinks" if sign > 0 else "grows"
            out.append(
                f"{seen.head}: {key} {name}: {turn} back on the way, to {low} px from {peak} px "
                f"(more than {100 * GROWTH_DIP:.0f} %) at t = {time_spans(seen.times, back)}"
            )
    return out


def matching(name: str, objects: Sequence[str]) -> list[str]:
    """The objects a claim's ``name`` stands for: that object and its pieces ("NAME 2", ...),
    by the one rule of exhibit.timelines.object_names (aliases are resolved when the timeline
    is loaded)."""
    from exhibit.timelines.object_names import matching as names_matching

    return names_matching(name, objects)


def distance(r: float) -> str:
    return "inf" if r <= 0 else f"{1 / r:.3g}"


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
