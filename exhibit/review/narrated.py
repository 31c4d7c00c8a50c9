"""The narrated review (`exhibit render --timeline FILE --narration`): the timeline as the kiosk
plays it after a listen press, every caption held until its words are spoken, with what was
spoken taken off the review's tape (exhibit.narration.tape): each segment's start, end, keyframe
and words, the segments that could not be made, and the sound itself.

The command (exhibit.commands._review) writes the frames and this track out."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from exhibit.narration.tape import TapePlayer
from exhibit.review.player import KioskPlayer, ReviewFrame

if TYPE_CHECKING:
    from exhibit.narration.sound import Sound

#: A narrated review draws at most this many times the timeline's own length (the holds).
NARRATED_STRETCH = 3.0


def play_narrated(
    player: KioskPlayer, fps: float, progress: Callable[[int], object] | None = None
) -> Iterator[tuple[ReviewFrame, float]]:
    """``player``'s frames (made with ``narrate=True``) until its timeline has played to the end,
    however long the narration holds it (NARRATED_STRETCH times its length at most): (frame,
    time into the timeline) pairs."""
    return player.play_through(fps, progress=progress, limit_s=NARRATED_STRETCH * player.duration)


@dataclass
class NarrationTrack:
    """What the narrated review spoke in its first ``length`` seconds."""

    #: each spoken segment: start, end (s of the review), keyframe, language, text (recording)
    segments: list[dict[str, Any]]
    #: the narrator's failures as the health file names them
    failed: list[Any]
    #: one line per problem (a hung engine's skipped segments counted, not listed)
    problems: list[str]
    sound: Sound


def narration_track(player: KioskPlayer, length: float) -> NarrationTrack:
    """The narration of the ``length`` seconds ``player`` has played."""
    narrator = player.kiosk.narrator
    tape = narrator.player
    assert isinstance(tape, TapePlayer)  # a review's narration goes onto tape (KioskPlayer)
    spoken = [
        {
            "start": round(take.start, 4),
            "end": round(min(take.end, length), 4),
            "keyframe": segment.keyframe,
            "language": segment.language,
            "text": segment.text,
            **({"recording": segment.recording} if segment.recording else {}),
        }
        for (_, _, segment), take in zip(narrator.history, tape.takes)
        if take.start < length
    ]
    failed = narrator.status()["failed"]
    report = narrator.failures()  # a hung engine's skipped segments counted, not listed
    return NarrationTrack(spoken, failed, report, tape.mixdown(length))
