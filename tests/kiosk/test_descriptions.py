"""The shipped attract timelines' spoken descriptions (a keyframe's ``describe``, spoken before
its caption: exhibit/timelines/file.py): every caption has one, short, complementing it, and
translated. How long they take against the time their captions are shown is measured on the real
speech in tests/kiosk/test_narrated_review.py (the kiosk holds a caption until spoken)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from exhibit import scenes
from exhibit.timelines.file import load_playlist
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.language import load_catalogues

MAX_DESCRIPTION = 300  # characters


def caption_windows():
    """(timeline stem, keyframe index, keyframe, window in seconds) for every keyframe that
    sets a caption in the shipped playlist."""
    config = load_kiosk_config()
    out = []
    for timeline in load_playlist(config.attract_dir, scenes.get):
        raw = tomllib.loads(Path(timeline.path).read_text(encoding="utf-8"))["keyframe"]
        setting = [i for i, k in enumerate(raw) if "caption" in k]
        ends = [timeline.keyframes[i].t for i in setting[1:]] + [timeline.duration]
        for i, end in zip(setting, ends):
            keyframe = timeline.keyframes[i]
            out.append((Path(timeline.path).stem, i, keyframe, end - keyframe.t))
    return out


WINDOWS = caption_windows()


def test_there_are_captions_to_check():
    assert len({stem for stem, *_ in WINDOWS}) == 7 and len(WINDOWS) == 31


@pytest.mark.parametrize(
    "stem,i,keyframe,window", WINDOWS, ids=[f"{s}:{i}" for s, i, *_ in WINDOWS]
)
def test_every_caption_has_a_short_description(stem, i, keyframe, window):
    assert keyframe.description, f"{stem}: keyframe {i}: a caption without a description"
    assert len(keyframe.description) <= MAX_DESCRIPTION
    assert keyframe.description not in keyframe.caption  # it complements, not repeats


def test_every_description_has_its_german():
    config = load_kiosk_config()
    german = load_catalogues(config.catalogues_dir, ["de"])["de"]
    missing = [(stem, i) for stem, i, k, _ in WINDOWS if k.description not in german.text]
    assert not missing
