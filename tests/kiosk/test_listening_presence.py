"""Listening is presence (issue 42): a visitor who presses listen and then only listens is not
taken for an empty room. The idle return counts from the end of the words they asked for, not
from their last turn. On a simulated clock, with the kiosk's state and narration cues and a
player whose sounds last as long as the test says."""

from __future__ import annotations

import tomllib
from types import SimpleNamespace

import pytest

from exhibit import scenes
from exhibit.devices.base import Event, Kind
from exhibit.devices.config import parse_config
from exhibit.devices.mapping import Mapper
from exhibit.kiosk.narration_cues import NarrationCues
from exhibit.kiosk.narrator import Narrator
from exhibit.kiosk.state import ATTRACT, VISITOR, KioskState
from exhibit.timelines.file import load_timeline
from exhibit.timelines.playlist import Playlist
from tests.kiosk.support import DEVICES, TIMELINE

IDLE_S = 30.0
#: How long the visitor's scene takes to say (title and caption).
SPOKEN_S = 40.0
LISTEN = """
[[mapping.bind]]
device = "knobs"
input = "button 2"
action = "listen"
"""


class Player:
    """Plays each sound for SPOKEN_S on the test's clock."""

    def __init__(self):
        self.now = 0.0
        self.until = 0.0

    def play(self, sound) -> None:
        self.until = self.now + SPOKEN_S

    def stop(self) -> None:
        self.until = self.now

    @property
    def playing(self) -> bool:
        return self.now < self.until

    def status(self) -> dict:
        return {"state": "ok", "device": None, "error": None}

    def close(self) -> None:
        pass


@pytest.fixture
def kiosk(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(TIMELINE)
    timeline = load_timeline(path, scenes.get)
    config = parse_config(tomllib.loads(DEVICES + LISTEN), "<test>")
    state = KioskState(
        Playlist([timeline]), Mapper(config.mapping), ("hopf",), IDLE_S, blend_s=2.0, now=0.0
    )
    player = Player()
    narrator = Narrator(
        [timeline], ["en"], lambda text, code: text, player, make=lambda s: s, background=False
    )
    cues = NarrationCues(narrator, SimpleNamespace(language="en"))
    return state, cues, player


def run(kiosk, until: float, presses: dict[float, list[Event]]) -> dict[float, str]:
    """Frames every 0.5 s as the kiosk steps them (listen, update, speak); the mode at each."""
    state, cues, player = kiosk
    modes = {}
    t = 0.0
    while t <= until:
        player.now = t
        events = cues.listen(state, presses.get(t, []), t)
        frame = state.update(events, t)
        cues.speak(state, frame, t)
        modes[t] = frame.mode
        t += 0.5
    return modes


def knob(t: float) -> Event:
    return Event(t, "knobs", Kind.REL, 0, 1.0)


def listen(t: float) -> list[Event]:
    return [Event(t, "knobs", Kind.BUTTON, 1, 1.0), Event(t + 0.01, "knobs", Kind.BUTTON, 1, 0.0)]


def test_a_visitor_who_presses_listen_and_listens_stays_until_the_words_end(kiosk):
    """Turned once at 5 s, listen at 6 s (40 s of words, to 46 s): still theirs at 70 s, and
    attract mode IDLE_S after the words ended. Before: attract at 35 s, mid-sentence."""
    modes = run(kiosk, 80.0, {5.0: [knob(5.0)], 6.0: listen(6.0)})
    assert modes[4.0] == ATTRACT and modes[5.0] == VISITOR
    assert modes[36.0] == VISITOR and modes[70.0] == VISITOR
    returned = min(t for t, mode in modes.items() if t > 5.0 and mode == ATTRACT)
    assert 46.0 + IDLE_S <= returned <= 46.0 + IDLE_S + 1.0


def test_a_press_alone_is_presence_and_narration_off_is_not(kiosk):
    """Listen pressed on and off again at once (no words): the idle return counts from the
    press, not from speech that is not there."""
    state, cues, player = kiosk
    modes = run(kiosk, 60.0, {5.0: [knob(5.0)], 20.0: listen(20.0), 20.5: listen(20.5)})
    assert modes[49.0] == VISITOR
    returned = min(t for t, mode in modes.items() if t > 5.0 and mode == ATTRACT)
    assert 20.5 + IDLE_S <= returned <= 20.5 + IDLE_S + 1.0
