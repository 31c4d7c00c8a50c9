"""What a timeline says aloud: one segment per keyframe that states a caption or a description,
spoken from that keyframe until the next such one (its window), in one language.

A segment's words are the keyframe's description (what the picture shows, for a visitor who
cannot see it) and then the caption on screen, both in the visitor's language; a curator's
recording for that keyframe and language is spoken instead of both. Pure: no audio, no I/O."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import PurePath

from exhibit.timelines.model import Timeline


@dataclass(frozen=True)
class Segment:
    #: the keyframe that starts it (an index into the timeline's keyframes)
    keyframe: int
    #: its window: seconds into the timeline from its keyframe to the next segment's
    start: float
    end: float
    #: the words, in the segment's language (description, then caption)
    text: str
    language: str
    #: a curator's recording for this keyframe and language (a path beside the timeline), spoken
    #: instead of text; it must lie within ``root``, the timeline's folder
    recording: str | None = None
    root: str | None = None

    @property
    def window(self) -> float:
        return self.end - self.start


def speaks(timeline: Timeline, i: int) -> bool:
    """Whether keyframe ``i`` starts a segment: it states a description or a recording, or shows
    a caption other than the one before it."""
    k = timeline.keyframes[i]
    new_caption = bool(k.caption) and (i == 0 or k.caption != timeline.keyframes[i - 1].caption)
    return bool(k.description or k.recordings) or new_caption


def segments(
    timeline: Timeline, language: str, translate: Callable[[str, str], str]
) -> list[Segment]:
    """The timeline's segments in ``language``; ``translate(english, language)`` gives a text
    in that language (exhibit.kiosk.language's catalogues: English where there is none)."""
    starts = [i for i in range(len(timeline.keyframes)) if speaks(timeline, i)]
    out = []
    for n, i in enumerate(starts):
        k = timeline.keyframes[i]
        end = timeline.keyframes[starts[n + 1]].t if n + 1 < len(starts) else timeline.duration
        words = [translate(text, language) for text in (k.description, k.caption) if text]
        out.append(
            Segment(
                keyframe=i,
                start=k.t,
                end=end,
                text=" ".join(w.strip() for w in words if w.strip()),
                language=language,
                recording=dict(k.recordings).get(language),
                root=str(PurePath(timeline.path).parent),
            )
        )
    return [s for s in out if s.text or s.recording]


def segment_at(parts: Sequence[Segment], t: float) -> int | None:
    """The index of the segment whose window holds ``t`` (None before the first)."""
    found = None
    for n, s in enumerate(parts):
        if s.start <= t:
            found = n
    return found
