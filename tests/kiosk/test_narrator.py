"""The kiosk's narrator (exhibit.kiosk.narrator) and the timeline's spoken script
(exhibit.narration.script), with a player that keeps a clock of its own: what is spoken when,
once each, and how long attract mode holds a caption for it."""

from __future__ import annotations

from pathlib import Path

import pytest

from exhibit import scenes
from exhibit.timelines.file import load_timeline, timeline_paths
from exhibit.kiosk.narrator import Narrator
from exhibit.narration.script import segment_at, segments
from exhibit.resources import shipped

TIMELINE = """
scene = "hopf"
[[keyframe]]
t = 0
caption = "Three doughnuts."
describe = "Three rings in the middle of the screen."
[[keyframe]]
t = 4
angles = [0, 0, 0, 10, 0, 0]
[[keyframe]]
t = 6
caption = "Closer."
[[keyframe]]
t = 10
caption = "Closer."
describe = "The left ring grows."
narration = { de = "k3-de.wav" }
[[keyframe]]
t = 14
"""


class Sound:
    def __init__(self, text: str, seconds: float):
        self.text, self.duration = text, seconds


class Player:
    """Plays a sound for its duration on a clock the test moves."""

    def __init__(self):
        self.now = 0.0
        self.played: list[tuple[float, str]] = []
        self._until = 0.0
        self.closed = False

    def play(self, sound) -> None:
        self.played.append((self.now, sound.text))
        self._until = self.now + sound.duration

    def stop(self) -> None:
        self._until = self.now

    @property
    def playing(self) -> bool:
        return self.now < self._until

    def status(self) -> dict:
        return {"state": "ok", "device": None, "error": None}

    def close(self) -> None:
        self.closed = True


@pytest.fixture()
def timeline(tmp_path):
    scenes.load()
    path = tmp_path / "t.toml"
    path.write_text(TIMELINE)
    return load_timeline(path, scenes.get)


def words(seconds_per_word: float = 0.4):
    return lambda segment: Sound(segment.text, seconds_per_word * len(segment.text.split()))


def translate(text: str, code: str) -> str:
    return text if code == "en" else f"[{code}] {text}"


def test_a_segment_per_new_caption_or_description_each_its_window(timeline):
    parts = segments(timeline, "en", translate)
    assert [(s.keyframe, s.start, s.end) for s in parts] == [(0, 0, 6), (2, 6, 10), (3, 10, 14)]
    assert parts[0].text == "Three rings in the middle of the screen. Three doughnuts."
    assert parts[1].text == "Closer."  # a caption without a description
    assert parts[2].text == "The left ring grows. Closer."  # the same caption, described anew
    assert parts[2].recording is None
    german = segments(timeline, "de", translate)
    assert german[0].text == "[de] Three rings in the middle of the screen. [de] Three doughnuts."
    assert german[2].recording == str(Path(timeline.path).parent / "k3-de.wav")
    assert german[2].root == str(Path(timeline.path).parent)
    assert [segment_at(parts, t) for t in (0, 5.9, 6, 13)] == [0, 0, 1, 2]


def test_off_until_pressed_then_each_segment_once_and_off_again(timeline):
    player = Player()
    narrator = Narrator([timeline], ["en"], translate, player, make=words(), background=False)
    assert not narrator.on(attract_mode=True)  # attract mode is silent by default
    narrator.press()
    assert narrator.on(attract_mode=True)
    for now in (1.0, 1.1, 2.0):
        player.now = now
        narrator.speak_timeline(timeline, now, "en", now)
    assert player.played == [(1.0, "Three rings in the middle of the screen. Three doughnuts.")]
    narrator.press()
    assert not narrator.on(attract_mode=True) and not player.playing


def test_attract_mode_holds_a_caption_until_its_words_are_spoken(timeline):
    player = Player()
    narrator = Narrator([timeline], ["en"], translate, player, make=words(1.0), background=False)
    narrator.press()
    player.now = 0.0
    narrator.speak_timeline(timeline, 0.0, "en", 0.0)  # 10 words: 10 s, in a window of 6 s
    player.now = 5.0
    assert narrator.hold_at(timeline, 5.0, "en") is None  # not at the window's end yet
    player.now = 6.5
    hold = narrator.hold_at(timeline, 6.5, "en")
    assert hold is not None and 5.99 < hold < 6.0  # the first caption stays on screen
    player.now = 10.0
    assert narrator.hold_at(timeline, 6.5, "en") is None  # spoken: on to the next caption


def test_a_visitor_walking_away_stops_it_and_the_site_may_narrate_attract_mode(timeline):
    player = Player()
    narrator = Narrator([timeline], ["en"], translate, player, make=words(), background=False)
    narrator.press()
    narrator.speak_timeline(timeline, 0.5, "en", 0.5)
    narrator.walked_away()
    assert not narrator.on(attract_mode=True) and not player.playing
    site = Narrator([timeline], ["en"], translate, Player(), attract=True, make=words())
    assert site.on(attract_mode=True) and not site.on(attract_mode=False)


def test_a_sound_that_cannot_be_made_is_skipped_and_reported(timeline):
    def broken(segment):
        raise ValueError("no voice for this language")

    player = Player()
    narrator = Narrator([timeline], ["en"], translate, player, make=broken, background=False)
    narrator.press()
    narrator.speak_timeline(timeline, 0.0, "en", 0.0)
    assert player.played == []
    assert narrator.hold_at(timeline, 6.5, "en") is None  # attract mode does not wait
    status = narrator.status()
    assert status["on"] and "no voice" in status["failed"][0]


def test_every_shipped_timeline_has_a_script_in_every_language():
    scenes.load()
    for path in timeline_paths(shipped("configs", "attract")):
        timeline = load_timeline(path, scenes.get)
        for code in ("en", "de"):
            parts = segments(timeline, code, translate)
            assert parts, path
            assert all(s.end > s.start for s in parts)
