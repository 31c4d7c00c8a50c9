"""Every shipped timeline narrated as the kiosk speaks it after a listen press (issue 35), played
headlessly on the review's clock with the real speech engine: each caption is on screen for as
long as its narration speaks, every segment is spoken whole and starts at its keyframe, and no
speech runs past the keyframe that ends its caption (attract mode holds the caption instead)."""

from __future__ import annotations

import pytest

from exhibit.timelines.file import timeline_paths
from exhibit.review.player import KioskPlayer
from exhibit.narration import speech
from exhibit.narration.script import segments
from exhibit.resources import shipped

FPS = 4
SIZE = (192, 108)
PATHS = timeline_paths(shipped("configs", "attract"))


def cases():
    for path in PATHS:
        for language in ("en", "de"):
            fast = path.name.startswith("02-") and language == "de"
            marks = () if fast else (pytest.mark.slow,)
            yield pytest.param(path, language, marks=marks, id=f"{path.stem}-{language}")


@pytest.mark.skipif(not speech.available(), reason="espeak-ng is not installed (bootstrap.sh)")
@pytest.mark.parametrize("path, language", list(cases()))
def test_each_caption_stays_while_its_narration_speaks(path, language):
    with KioskPlayer(SIZE, timeline=path, language=language, narrate=True) as player:
        frames = list(player.play_through(FPS, limit_s=4 * player.duration))
        narrator = player.kiosk.narrator
        tape = narrator.player
        translate = player.kiosk.translate
        timeline = player.timeline
        assert timeline is not None
        last = frames[-1][0].t  # (the step that found the loop's start began it again)
        spoken = [(h, take) for h, take in zip(narrator.history, tape.takes) if take.start <= last]
        expected = segments(timeline, language, lambda text, code: translate(text, code))
    assert frames[-1][1] >= timeline.duration - 0.5  # played to its end
    assert [segment.keyframe for (_, _, segment), _ in spoken] == [s.keyframe for s in expected]
    assert not narrator.status()["failed"]
    for (_, _, segment), take in spoken:
        assert take.end - take.start == pytest.approx(take.sound.duration)  # spoken whole
        keyframe = timeline.keyframes[segment.keyframe]
        caption = translate(keyframe.caption, language)
        during = [(f, into) for f, into in frames if take.start <= f.t < take.end]
        assert during, segment
        # it starts when its keyframe comes (within a frame), and its caption stays up
        assert during[0][1] - segment.start < 1.0 / FPS + 1e-6
        assert all(f.caption == caption for f, _ in during), (segment.keyframe, caption)
        # no speech past the keyframe that ends its caption: the timeline is held before it
        assert all(into < segment.end for _, into in during)
