"""The shipped attract timelines' spoken descriptions (a keyframe's ``describe``, spoken before
its caption: exhibit/kiosk/attract.py) against the time their captions are shown.

A deterministic estimate, not the audio: speech at 2.5 words per second (about 150 words a
minute), German 20 % slower (it runs longer when spoken), words counted as runs of characters
between spaces. A caption's window runs from the keyframe that sets it to the next keyframe that
sets a caption, or the timeline's end; description + caption must be spoken in it with 1 s to
spare. The synthesised narration is measured against the same windows elsewhere (issue 35).

Some captions leave no room: they overrun their windows on their own, or a description of a
word or two tips them over. They are listed in OVERRUNS with what they lack, so a new overrun
fails here, and so does a listed one that fits again (the list only shrinks): while narration is
on, the kiosk holds a keyframe until its narration has been spoken, so an overrun there costs
the visitor waiting time, not words.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from exhibit.kiosk.attract import load_playlist
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.language import load_catalogues

WORDS_PER_S = 2.5
SLOWER = {"en": 1.0, "de": 1.2}
MARGIN_S = 1.0
MAX_DESCRIPTION = 300  # characters

#: (timeline file stem, keyframe index, language): seconds short by the estimate above. The
#: caption alone is already too long for its window in most; the rest are noted.
OVERRUNS = {
    ("01-hypersphere", 0, "en"): 2.4,
    ("01-hypersphere", 0, "de"): 2.16,
    ("01-hypersphere", 3, "en"): 0.6,  # a 4 s window; the caption fits alone
    ("01-hypersphere", 3, "de"): 1.32,
    ("01-hypersphere", 5, "en"): 2.0,  # the caption alone has 0.0 s to spare
    ("01-hypersphere", 5, "de"): 2.64,
    ("02-offset-parabola", 0, "en"): 1.8,
    ("02-offset-parabola", 0, "de"): 3.96,
    ("02-offset-parabola", 1, "de"): 0.8,  # the caption fits alone
    ("02-offset-parabola", 2, "de"): 1.12,  # the caption fits alone
    ("03-offset-cusp", 0, "en"): 1.4,  # the caption alone has 0.2 s to spare
    ("03-offset-cusp", 0, "de"): 3.48,
    ("03-offset-cusp", 2, "de"): 2.6,
    ("04-collision-15", 0, "de"): 1.12,  # the caption fits alone
    ("05-collision-16", 0, "de"): 2.56,  # the caption fits alone
    ("06-collision-17", 0, "de"): 2.56,
    ("06-collision-17", 4, "en"): 2.4,
    ("06-collision-17", 4, "de"): 6.48,
    ("06-collision-17", 5, "de"): 1.64,
    ("06-collision-17", 6, "en"): 2.0,
    ("06-collision-17", 6, "de"): 2.64,
    ("06-collision-17", 7, "en"): 2.0,
    ("06-collision-17", 7, "de"): 4.56,
}


def spoken_s(text: str, language: str) -> float:
    return len(text.split()) / WORDS_PER_S * SLOWER[language]


def caption_windows():
    """(timeline stem, keyframe index, keyframe, window in seconds) for every keyframe that
    sets a caption in the shipped playlist."""
    config = load_kiosk_config()
    out = []
    for timeline in load_playlist(config.attract_dir):
        raw = tomllib.loads(Path(timeline.path).read_text(encoding="utf-8"))["keyframe"]
        setting = [i for i, k in enumerate(raw) if "caption" in k]
        ends = [timeline.keyframes[i].t for i in setting[1:]] + [timeline.duration]
        for i, end in zip(setting, ends):
            keyframe = timeline.keyframes[i]
            out.append((Path(timeline.path).stem, i, keyframe, end - keyframe.t))
    return out


WINDOWS = caption_windows()


def spare_s():
    """{(stem, keyframe, language): seconds to spare}, for every caption in both languages."""
    config = load_kiosk_config()
    german = load_catalogues(config.catalogues_dir, ["de"])["de"]
    spare = {}
    for stem, i, keyframe, window in WINDOWS:
        for language in SLOWER:
            texts = [keyframe.description, keyframe.caption]
            if language != "en":
                assert all(t in german.text for t in texts), f"{stem}: keyframe {i}: no German"
                texts = [german.text[t] for t in texts]
            spare[stem, i, language] = window - MARGIN_S - spoken_s(" ".join(texts), language)
    return spare


def test_there_are_captions_to_check():
    assert len({stem for stem, *_ in WINDOWS}) == 7 and len(WINDOWS) == 30


@pytest.mark.parametrize(
    "stem,i,keyframe,window", WINDOWS, ids=[f"{s}:{i}" for s, i, *_ in WINDOWS]
)
def test_every_caption_has_a_short_description(stem, i, keyframe, window):
    assert keyframe.description, f"{stem}: keyframe {i}: a caption without a description"
    assert len(keyframe.description) <= MAX_DESCRIPTION
    assert keyframe.description not in keyframe.caption  # it complements, not repeats


def test_description_and_caption_fit_the_caption_window_in_english_and_german():
    spare = spare_s()
    over = {key: round(-s, 2) for key, s in spare.items() if s < -1e-9}
    new = {key: short for key, short in over.items() if key not in OVERRUNS}
    assert not new, f"new overruns (seconds short): {new}"
    stale = set(OVERRUNS) - set(over)
    assert not stale, f"these fit now: remove them from OVERRUNS: {sorted(stale)}"
    for key, short in OVERRUNS.items():
        assert over[key] <= short + 1e-9, f"{key}: {over[key]} s short, was {short}"


def test_the_estimate_counts_words_and_slows_german():
    assert spoken_s("Closer still.", "en") == pytest.approx(0.8)
    assert spoken_s("Noch näher.", "de") == pytest.approx(0.96)
