"""espeak-ng speaks English and German offline; every text it cannot speak is a one-line
NarrationError. ./bootstrap.sh installs espeak-ng, so CI runs every test here."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

from exhibit import tools
from exhibit.narration import (
    RATE,
    NarrationError,
    SpeechBudget,
    SpeechSkipped,
    available,
    engine_version,
    spoken,
    synthesise,
)
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


def test_a_voice_is_data():
    """English's voice is the source's; every other language's comes from its catalogue."""
    from exhibit.kiosk.language import load_catalogues

    assert speech.voice_for("en") == speech.Voice("en-gb", 150)
    load_catalogues(None, ["de"])
    assert speech.voice_for("de") == speech.Voice("de", 150)


@pytest.mark.parametrize(
    "text, language, why",
    [
        ("   \n", "en", "blank"),
        ("", "de", "blank"),
        ("x" * (speech.MAX_TEXT_CHARS + 1), "en", "over the 2000"),
        ("Dzień dobry", "pl", "no espeak-ng voice for language 'pl'"),
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


def fake_engine(tmp_path, monkeypatch, body: str) -> Path:
    """A fake espeak-ng found where the real one is looked up; it appends its pid to
    ``tmp_path/pids`` (each call), then runs ``body``."""
    fake = tmp_path / "espeak-ng"
    fake.write_text(f'#!/bin/sh\necho $$ >> "{tmp_path / "pids"}"\n{body}\n')
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    return tmp_path / "pids"


def test_a_hung_engine_costs_its_limit_once_then_fails_fast(monkeypatch, tmp_path):
    """The first call waits its limit; every later call of the run fails at once with the
    same reason, without starting the engine again."""
    calls = fake_engine(tmp_path, monkeypatch, "exec sleep 1000")
    budget = SpeechBudget(call_s=0.3)
    begun = time.monotonic()
    with pytest.raises(NarrationError) as first:
        synthesise("Hello", "en", budget=budget)
    assert str(first.value) == "espeak-ng did not answer within 0.3 s (speaking 'Hello')"
    assert not isinstance(first.value, SpeechSkipped)
    for text in ("Two", "Three", "Four", "Five"):
        with pytest.raises(SpeechSkipped) as later:
            synthesise(text, "de", budget=budget)
        assert later.value.reason == str(first.value)
        assert str(later.value) == f"skipped: {first.value}"
    assert time.monotonic() - begun < 3.0  # 10 x one limit, not 5 limits waited
    assert len(calls.read_text().split()) == 1 and budget.skipped == 4


def test_the_call_limit_is_espeaks_own(monkeypatch, tmp_path):
    fake_engine(tmp_path, monkeypatch, "exec sleep 1000")
    monkeypatch.setattr(tools, "ESPEAK_CALL_S", 0.3)
    with pytest.raises(NarrationError, match=r"did not answer within 0\.3 s \(speaking 'Hello'\)"):
        synthesise("Hello", "en")


def test_a_hung_version_question_stops_the_run(monkeypatch, tmp_path):
    fake_engine(tmp_path, monkeypatch, "exec sleep 1000")
    budget = SpeechBudget(call_s=0.3)
    with pytest.raises(NarrationError, match=r"within 0\.3 s \(asked its version\)"):
        engine_version(budget)
    with pytest.raises(SpeechSkipped):
        spoken("Hello", "en", tmp_path / "cache", budget=budget)


SLOW = f"""sleep 0.4
exec {sys.executable} -c 'import sys, wave
w = wave.open(sys.stdout.buffer, "wb")
w.setnchannels(1); w.setsampwidth(2); w.setframerate(22050); w.writeframes(bytes(4410))
w.close()'"""


def test_a_slow_engine_stops_at_the_runs_total(monkeypatch, tmp_path):
    """Each call answers well within its own limit, but all of them would take longer than the
    run may: the call that runs out names the total, the rest are skipped at once."""
    fake_engine(tmp_path, monkeypatch, SLOW)
    budget = SpeechBudget(call_s=30, total_s=1.0)
    begun = time.monotonic()
    reasons = []
    for n in range(8):
        try:
            synthesise(f"Segment {n}", "en", budget=budget)
        except SpeechSkipped as exc:
            reasons.append(("skipped", exc.reason))
        except NarrationError as exc:
            reasons.append(("stopped", str(exc)))
    assert time.monotonic() - begun < 10.0  # the total, not 8 calls of 30 s
    assert reasons[0][0] == "stopped" and "took over 1 s in all" in reasons[0][1]
    assert reasons[1:] == [("skipped", reasons[0][1])] * (len(reasons) - 1)
    assert len(reasons) < 8 and budget.spent_s < 5.0


def test_binary_bytes_from_the_engine_are_shown_replaced(monkeypatch, tmp_path):
    fake_engine(tmp_path, monkeypatch, r"printf 'bad \377\376 voice\n' >&2; exit 1")
    with pytest.raises(NarrationError, match="failed to speak 'Hello': bad \ufffd\ufffd voice"):
        synthesise("Hello", "en")


def test_garbage_output_is_refused(monkeypatch, tmp_path):
    fake = tmp_path / "espeak-ng"
    fake.write_text("#!/bin/sh\necho not a wav file\n")
    fake.chmod(0o755)
    monkeypatch.setattr(speech.shutil, "which", lambda name: str(fake))
    with pytest.raises(NarrationError, match="espeak-ng output for 'Hello': not a WAV"):
        synthesise("Hello", "en")
