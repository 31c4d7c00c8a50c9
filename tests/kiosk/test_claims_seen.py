"""Claims measured as a visitor sees them (issue 41): motion and growth over the whole caption,
not its ends; tags held to the frame; every mark named by some word. Pure: synthetic samples
and HUD records, no GL (tests/kiosk/test_claims.py plays the kiosk)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from exhibit import scenes
from exhibit.geometry.view import ViewState
from exhibit.render.hud import TextMark
from exhibit.render.layout import Rect
from exhibit.review.marks_named import FrameWords, unexplained_problems
from exhibit.review.tags_seen import TagFault, tag_faults, tag_problems
from exhibit.timelines.captions import caption_problems
from exhibit.timelines.claims.base import GROWTH_DIP, Sample, Seen
from exhibit.timelines.claims.grows import Grows
from exhibit.timelines.claims.sensor_motion import SensorMotion
from exhibit.timelines.claims.shrinks import Shrinks
from exhibit.timelines.file import load_timeline
from exhibit.timelines.model import Condition

SIZE = (100, 50)


def _seen(areas, name="ring", r=None, stepped=False, step=0.5):
    r = r or [0.0] * len(areas)
    samples = [
        Sample(j * step, ViewState(sensor_r=r[j]), {name: a}, SIZE, (name,))
        for j, a in enumerate(areas)
    ]
    return Seen(samples, 0, "f: keyframe 0: while", "f: keyframe 0", {name: [name]}, stepped)


def test_grows_holds_sample_by_sample_not_only_end_to_end():
    """The green doughnut peaked at 8,144 px and fell back to 7,682 before the caption ended:
    end to end it grew, on the way it shrank by 5.7 %, more than GROWTH_DIP."""
    assert Grows(("ring",)).problems(_seen([4000, 6000, 8144, 8100, 8144])) == []
    (line,) = Grows(("ring",)).problems(_seen([4000, 6000, 8144, 7682, 7682]))
    assert line == (
        "f: keyframe 0: grows ring: shrinks back on the way, to 7682 px from 8144 px (more than "
        "3 %) at t = 1.5..2.0 s"
    )
    wobble = 8144 * (1 - 0.5 * GROWTH_DIP)
    assert Grows(("ring",)).problems(_seen([4000, 8144, wobble, 9000])) == []
    (line,) = Shrinks(("ring",)).problems(_seen([9000, 4000, 5000, 3000]))
    assert "grows back on the way, to 5000 px from 4000 px" in line


def _motion(r, stepped=False, step=0.5):
    return SensorMotion("closer").problems(_seen([1] * len(r), r=r, stepped=stepped, step=step))


def test_sensor_motion_holds_over_the_whole_caption():
    """ "Now the 4D viewpoint moves closer" shown 3 s after the sensor stopped (of 11 s): 27 %
    of its time still, more than the tolerance; a moment still at the start is within it."""
    moving = [0.1 * j for j in range(17)]  # 8 s of motion, sampled every 0.5 s
    assert _motion(moving + [1.6] * 2) == []
    (line,) = _motion(moving + [1.6] * 6)
    assert line.startswith("f: keyframe 0: while.sensor_motion: the caption says 'closer', but")
    assert "stands still at 0.625 at t = 8.0..11.0 s (27 % of its time, more than 20 %)" in line


def test_reduced_motion_may_hold_a_step_but_not_longer():
    """Held steps (reduced motion) stand still about 4 s at a time; a 5.5 s hold at the end is a
    caption outstaying its motion."""
    steps = [0.0] * 8 + [0.5] * 8 + [1.0] * 2
    assert _motion(steps, stepped=True) == []
    (line,) = _motion(steps + [1.0] * 10, stepped=True)
    assert line.endswith("stands still at t = 8.0..13.5 s (longer than a held step, 4.5 s)")


def test_check_config_finds_a_motion_caption_that_outstays_its_motion(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text(
        'scene = "hopf"\n[[keyframe]]\nt = 0\nsensor_distance = "inf"\ncaption = "Closer."\n'
        'while = { sensor_motion = "closer" }\n[[keyframe]]\nt = 8\nsensor_distance = 3\n'
        '[[keyframe]]\nt = 11\ncaption = "Stop."\n[[keyframe]]\nt = 15\n'
    )
    (line,) = caption_problems(load_timeline(path, scenes.get))
    assert "stands still at 3 at t = 8.0..11.0 s (27 % of its time" in line


def _hud(tags, texts=()):
    """A HUD's record: tags as (words, rect, point, object)."""
    return SimpleNamespace(
        tags=[(w, Rect(*r), p, False) for w, r, p, _ in tags],
        tag_objects=[o for *_, o in tags],
        texts=list(texts),
    )


def test_a_tags_leader_must_end_on_its_object():
    image = np.zeros((50, 100), dtype=np.int64)
    image[10:20, 10:20] = 1  # "ring"
    image[30:40, 60:70] = 2  # "disc"
    names = ["ring", "disc"]
    good = _hud([("ring", (40, 0, 55, 8), (15.0, 15.0), "ring")])
    assert tag_faults(good, image, names, (100, 50), []) == ()
    bad = _hud([("ring", (40, 0, 55, 8), (65.0, 35.0), "ring")])
    assert tag_faults(bad, image, names, (100, 50), []) == (
        TagFault("ring", "off its object", "ring"),
    )


def test_tags_cross_no_panel_no_words_no_other_tag_and_keep_apart():
    image = np.ones((720, 1280), dtype=np.int64)
    names = ["ring", "disc"]
    panel = Rect(0, 0, 300, 100)
    label = TextMark("marker label", "first contact", Rect(500, 380, 640, 400), (1, 1, 1, 1))
    hud = _hud(
        [
            ("ring", (400, 50, 480, 70), (600, 300), "ring"),  # leader runs down-right
            ("disc", (520, 390, 600, 410), (610, 312), "disc"),  # 15 px from the ring's end
            ("ring too", (100, 50, 200, 70), (210, 200), "ring"),  # on the panel
        ],
        [label],
    )
    faults = tag_faults(hud, image, names, (1280, 720), [panel])
    assert TagFault("ring too", "crosses", "a panel") in faults
    assert TagFault("disc", "crosses", "the words 'first contact' (marker label)") in faults
    assert TagFault("ring", "near", "disc") in faults
    assert not any(f.kind == "near" and f.words == "ring too" for f in faults)  # same object
    # one sample at a time is the anchors' re-test lag, not a misplaced tag
    assert tag_problems("f: keyframe 2", [1.0, 1.5, 2.0], [faults, (), faults]) == []
    lines = tag_problems("f: keyframe 2", [1.0, 1.5, 2.0], [faults, faults, ()])
    assert "f: keyframe 2: tag 'ring too': its words or leader cross a panel at t = 1.0..1.5 s" in (
        lines
    )


@pytest.mark.parametrize(
    "named, labels, claims, found",
    [
        (frozenset(), (), (), ["'wire pipe'", "'outline'"]),
        (frozenset({"outline"}), ("wire pipe",), (), []),  # the key names outlines
        (frozenset(), (), (Grows(("wire pipe",)),), ["'outline'"]),  # a claim names the pipe
    ],
)
def test_every_mark_a_visitor_notices_is_named_by_some_word(named, labels, claims, found):
    objects = ("wire pipe", "outline", "speck")
    sample = Sample(
        0.0, ViewState(), {"wire pipe": 500, "outline": 60, "speck": 1}, (640, 360), objects
    )
    lines = unexplained_problems(Condition(claims), labels, [sample], [FrameWords(named)], "f: k 0")
    assert [line.split(" covers")[0].split(": ")[-1] for line in lines] == found
