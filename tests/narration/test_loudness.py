"""Narration's loudness (issue 42, item 4): every sound it plays, synthesised or recorded, sits at
one BS.1770 loudness with at least 1 dB of true-peak headroom, measured here on its own (pyloudnorm
for the loudness, 4x oversampling for the true peak), not through exhibit.narration.loudness."""

from __future__ import annotations

import math

import numpy as np
import pyloudnorm
import pytest
from scipy.signal import resample_poly

from exhibit.narration import RATE, Sound, load_recording, loudness, speech, spoken, synthesise
from exhibit.narration.cache import speech_key
from tests.narration.support import pcm_wav, sine

TARGET = -23.0  # LUFS: the target docs/KIOSK.md promises

needs_espeak = pytest.mark.skipif(
    not speech.available(),
    reason="espeak-ng is not installed (apt-get install espeak-ng; bootstrap.sh does)",
)


def lufs(sound: Sound) -> float:
    return float(pyloudnorm.Meter(RATE).integrated_loudness(sound.samples / 32768.0))


def dbtp(sound: Sound) -> float:
    over = resample_poly(sound.samples / 32768.0, 4, 1)
    return 20 * math.log10(float(np.abs(over).max()))


def at_target(sound: Sound) -> None:
    assert lufs(sound) == pytest.approx(TARGET, abs=1.0)
    assert dbtp(sound) <= -1.0


def noise(seconds: float, rate: int, amplitude: float, seed: int = 4) -> np.ndarray:
    """Speech-like noise: white noise under a 4 Hz syllable envelope."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    envelope = 0.5 + 0.5 * np.abs(np.sin(2 * np.pi * 2 * t))
    signal = rng.standard_normal(len(t)) * envelope
    return amplitude * signal / np.abs(signal).max()


@pytest.fixture
def root(tmp_path):
    folder = tmp_path / "timelines"
    folder.mkdir()
    return folder


def recording(root, name: str, signal: np.ndarray, rate: int = 48000, bits: int = 24):
    path = root / name
    path.write_bytes(pcm_wav(signal, rate, bits))
    return path


def test_a_loud_recording_is_brought_down_to_the_target(root):
    path = recording(root, "loud.wav", noise(3.0, 48000, 0.999))  # peaks at full scale
    at_target(load_recording(path, root))


def test_a_quiet_stereo_recording_is_brought_up_to_the_target(root):
    quiet = sine(330, 2.0, 44100, amplitude=0.01)  # about -44 LUFS
    path = recording(root, "quiet.wav", np.stack([quiet, quiet], axis=1), rate=44100, bits=16)
    at_target(load_recording(path, root))


@needs_espeak
def test_synthesised_speech_is_at_the_target():
    for text, language in [
        ("The surface passes through itself along a curve: here its two sheets meet.", "en"),
        ("Die Fläche durchdringt sich selbst entlang einer Kurve.", "de"),
        ("Look.", "en"),
    ]:
        at_target(synthesise(text, language))


@needs_espeak
def test_speech_from_the_cache_and_a_recording_sound_equally_loud(tmp_path, root):
    text = "It never stretches; only its shadow does."
    first = spoken(text, "en", tmp_path / "cache")
    again = spoken(text, "en", tmp_path / "cache")  # read back from the cache
    assert np.array_equal(first.samples, again.samples)
    path = recording(root, "curator.wav", noise(4.0, 48000, 0.9))
    recorded = load_recording(path, root)
    for sound in (again, recorded):
        at_target(sound)
    assert abs(lufs(again) - lufs(recorded)) <= 1.0


@needs_espeak
def test_speech_cached_at_another_level_is_made_again(monkeypatch):
    """The loudness processing is part of the cache's key: speech cached before it (or at
    another target) misses instead of playing at its old level."""
    before = speech_key("Hello", "en")
    monkeypatch.setattr(speech, "PROCESSING", "bs1770 -16 LUFS -1 dBTP")
    assert speech_key("Hello", "en") != before


def test_a_word_shorter_than_a_gating_block_is_measured():
    word = Sound((0.5 * 32767 * sine(300, 0.25, RATE)).astype(np.int16))
    out = loudness.normalise(word)
    longer = Sound(np.tile(out.samples, 8))  # the same level, long enough for pyloudnorm
    assert lufs(longer) == pytest.approx(TARGET, abs=1.0)
    assert dbtp(out) <= -1.0


def test_silence_is_left_alone():
    quiet = Sound(np.zeros(RATE, dtype=np.int16))
    assert loudness.normalise(quiet) is quiet
    assert loudness.measure(quiet).loudness == -math.inf


def test_peaks_win_over_loudness():
    """A click over a quiet tone cannot reach the target without passing the ceiling: its
    gain stops at the ceiling, and the note says it will sound quieter."""
    x = 0.003 * sine(440, 2.0, RATE)
    x[RATE] = 0.9
    sound = Sound(np.rint(x * 32767).astype(np.int16))
    out = loudness.normalise(sound)
    assert dbtp(out) <= -1.0
    assert dbtp(out) > -1.5
    assert lufs(out) < TARGET - 1.0
    note = loudness.far_off("click.wav", loudness.measure(sound))
    assert note is not None and "click.wav" in note and "quieter than the rest" in note


def test_a_recording_near_the_target_gets_no_note_and_one_far_off_does():
    near = loudness.Level(TARGET + 3.0, -10.0)
    far = loudness.Level(TARGET + 9.5, -0.01)
    assert loudness.far_off("near.wav", near) is None
    note = loudness.far_off("audio/far.wav", far)
    assert note is not None and note.startswith("warning: audio/far.wav: ")
    assert "9.5 LU louder" in note
