"""espeak-ng speaks English and German offline; every text it cannot speak is a one-line
NarrationError. ./bootstrap.sh installs espeak-ng, so CI runs every test here."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit.narration import RATE, VOICES, NarrationError, available, engine_version, synthesise
from exhibit.narration import speech

needs_espeak = pytest.mark.skipif(
    not available(),
    reason="espeak-ng is not installed (apt-get install espeak-ng; bootstrap.sh does)",
)


@needs_espeak
@pytest.mark.parametrize(
    "language, text",
    [
        ("en", "The surface turns slowly. Its silhouette folds where the light grazes it."),
        ("de", "Die Fläche dreht sich langsam. Ihr Umriss faltet sich, wo das Licht sie streift."),
    ],
)
def test_speaks_english_and_german(language, text):
    sound = synthesise(text, language)
    assert 2.0 < sound.duration < 10.0, sound.duration
    assert np.abs(sound.samples.astype(np.int32)).max() > 3000  # audible speech, not silence
    assert len(sound.samples) == round(sound.duration * RATE)


@needs_espeak
def test_a_faster_rate_is_shorter():
    text = "A torus in four dimensions, seen from a sensor moving around it."
    assert synthesise(text, "en", rate_wpm=250).duration < synthesise(text, "en").duration * 0.8


@needs_espeak
def test_a_text_that_looks_like_an_option_is_spoken():
    assert synthesise("--help -v xx", "en").duration > 0.5


@needs_espeak
def test_engine_version():
    assert engine_version()[0].isdigit()


def test_the_voices():
    assert set(VOICES) == {"en", "de"}


@pytest.mark.parametrize(
    "text, language, why",
    [
        ("   \n", "en", "blank"),
        ("", "de", "blank"),
        ("x" * (speech.MAX_TEXT_CHARS + 1), "en", "over the 2000"),
        ("Bonjour", "fr", "no espeak-ng voice for language 'fr'"),
        ("nul\0byte", "en", "NUL"),
    ],
)
def test_what_cannot_be_spoken_says_why(text, language, why):
    with pytest.raises(NarrationError, match=why) as info:
        synthesise(text, language)
    assert "\n" not in str(info.value)


def test_missing_espeak_names_the_package(monkeypatch):
    monkeypatch.setattr(speech.shutil, "which", lambda name: None)
    assert not available()
    with pytest.raises(NarrationError, match="apt-get install espeak-ng"):
        synthesise("Hello", "en")
    with pytest.raises(NarrationError, match="apt-get install espeak-ng"):
        engine_version()


def test_a_failing_engine_is_reported_with_its_message(monkeypatch, tmp_path):
    fake = tmp_path / "espeak-ng"
    fake.write_text("#!/bin/sh\necho 'Failed to read voice' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    with pytest.raises(NarrationError, match="failed to speak 'Hello': Failed to read voice"):
        synthesise("Hello", "en")


def test_runaway_output_is_cut_off(monkeypatch, tmp_path):
    fake = tmp_path / "espeak-ng"
    fake.write_text("#!/bin/sh\nexec cat /dev/zero\n")
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    monkeypatch.setattr(speech, "MAX_OUTPUT_BYTES", 1 << 20)
    with pytest.raises(NarrationError, match="wrote over 1048576 bytes"):
        synthesise("Hello", "en")


def test_a_hung_engine_times_out(monkeypatch, tmp_path):
    fake = tmp_path / "espeak-ng"
    fake.write_text("#!/bin/sh\nexec sleep 30\n")
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    monkeypatch.setattr(speech, "TIMEOUT_S", 0.3)
    with pytest.raises(NarrationError, match="took over 0.3 s"):
        synthesise("Hello", "en")


def test_garbage_output_is_refused(monkeypatch, tmp_path):
    fake = tmp_path / "espeak-ng"
    fake.write_text("#!/bin/sh\necho not a wav file\n")
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    with pytest.raises(NarrationError, match="espeak-ng output for 'Hello': not a WAV"):
        synthesise("Hello", "en")
