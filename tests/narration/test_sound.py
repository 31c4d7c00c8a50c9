"""Sounds: lengths of silence, concatenation and mixes; WAV decoding of every accepted format,
the refusal of every broken header, and resampling that keeps a tone's pitch."""

from __future__ import annotations

import os

import numpy as np
import pytest

from exhibit.narration import (
    RATE,
    NarrationError,
    Sound,
    concatenate,
    mix,
    read_wav_bytes,
    silence,
    write_wav,
)
from exhibit.narration.sound import wav_bytes
from tests.narration.support import float_wav, pcm_wav, peak_hz, sine, wav


def tone(seconds: float, value: int = 1000) -> Sound:
    return Sound(np.full(int(round(seconds * RATE)), value, dtype=np.int16))


def test_silence_has_its_length_and_nothing_in_it():
    s = silence(1.5)
    assert len(s.samples) == int(1.5 * RATE) and s.duration == pytest.approx(1.5)
    assert not s.samples.any()
    assert len(silence(-1).samples) == 0


def test_a_sound_is_read_only_mono_int16():
    s = Sound(np.zeros(10, dtype=np.int16))
    with pytest.raises(ValueError):
        s.samples[0] = 1
    with pytest.raises(ValueError, match="int16"):
        Sound(np.zeros(10, dtype=np.float32))
    with pytest.raises(ValueError, match="1-D"):
        Sound(np.zeros((10, 2), dtype=np.int16))


def test_concatenate_puts_the_gap_between_sounds_only():
    a, b, c = tone(1.0), tone(0.5), tone(0.25)
    joined = concatenate([a, b, c], gap_s=0.3)
    assert len(joined.samples) == len(a.samples) + len(b.samples) + len(c.samples) + 2 * round(
        0.3 * RATE
    )
    assert concatenate([a]).duration == a.duration
    assert concatenate([]).duration == 0
    gap = joined.samples[len(a.samples) : len(a.samples) + round(0.3 * RATE)]
    assert not gap.any()


def test_mix_places_each_sound_at_its_time_and_cuts_at_the_ends():
    out = mix([(0.5, tone(1.0, 100)), (-0.25, tone(0.5, 7)), (2.5, tone(1.0, 5))], duration=3.0)
    assert out.duration == pytest.approx(3.0)
    s = out.samples
    assert s[0] == 7 and s[int(0.24 * RATE)] == 7 and s[int(0.26 * RATE)] == 0
    assert s[int(0.6 * RATE)] == 100 and s[int(1.6 * RATE)] == 0
    assert s[-1] == 5
    assert mix([(5.0, tone(1.0))], 1.0).samples.any() == False  # noqa: E712 - after the end


def test_mix_saturates_instead_of_wrapping():
    loud = tone(0.1, 30000)
    assert mix([(0, loud), (0, loud)], 0.1).samples.max() == 32767
    quiet = tone(0.1, -30000)
    assert mix([(0, quiet), (0, quiet)], 0.1).samples.min() == -32768


def test_write_wav_round_trips(tmp_path):
    s = Sound((sine(440, 0.5, RATE) * 32767).astype(np.int16))
    write_wav(tmp_path / "a.wav", s)
    back = read_wav_bytes((tmp_path / "a.wav").read_bytes(), "a.wav")
    assert np.array_equal(back.samples, s.samples)
    assert [p for p in os.listdir(tmp_path) if p.endswith(".tmp")] == []


def test_write_wav_never_writes_through_a_fifo(tmp_path):
    os.mkfifo(tmp_path / "pipe.wav")
    with pytest.raises(OSError, match="FIFO"):
        write_wav(tmp_path / "pipe.wav", silence(0.1))


# ---------------------------------------------------------------------- every accepted format

SIGNAL = sine(440, 0.2, 22050, amplitude=0.5)


@pytest.mark.parametrize("bits", [8, 16, 24, 32])
@pytest.mark.parametrize("channels", [1, 2, 8])
def test_integer_pcm_of_every_width_and_channel_count(bits, channels):
    frames = np.repeat(SIGNAL[:, None], channels, axis=1)
    s = read_wav_bytes(pcm_wav(frames, 22050, bits), "x.wav")
    assert len(s.samples) == len(SIGNAL)
    expected = SIGNAL * 32768
    assert np.max(np.abs(s.samples - expected)) <= (260 if bits == 8 else 2)


@pytest.mark.parametrize("bits", [32, 64])
@pytest.mark.parametrize("extensible", [False, True])
def test_float_wav(bits, extensible):
    frames = np.stack([SIGNAL, SIGNAL], axis=1)
    s = read_wav_bytes(float_wav(frames, 22050, bits, extensible), "f.wav")
    assert np.max(np.abs(s.samples - SIGNAL * 32768)) <= 1


def test_extensible_24_bit_six_channels():
    frames = np.repeat(SIGNAL[:, None], 6, axis=1)
    data = pcm_wav(frames, 22050, 24)
    raw = data[data.index(b"data") + 8 :]
    s = read_wav_bytes(wav(raw, 22050, 6, 24, extensible=True), "surround.wav")
    assert np.max(np.abs(s.samples - SIGNAL * 32768)) <= 2


def test_channels_are_mixed_down_by_their_mean():
    opposite = np.stack([SIGNAL, -SIGNAL], axis=1)
    assert np.abs(read_wav_bytes(pcm_wav(opposite, 22050), "o.wav").samples).max() <= 1
    one_side = np.stack([SIGNAL, np.zeros_like(SIGNAL)], axis=1)
    half = read_wav_bytes(pcm_wav(one_side, 22050), "h.wav").samples
    assert np.max(np.abs(half - SIGNAL * 16384)) <= 2


def test_a_streaming_header_is_read_to_the_end_of_the_file():
    """espeak-ng --stdout cannot seek back, so it writes 0x7ffff000 as the data size."""
    data = pcm_wav(SIGNAL, 22050)
    raw = data[data.index(b"data") + 8 :]
    s = read_wav_bytes(wav(raw, 22050, 1, 16, data_size=0x7FFFF000), "stream.wav")
    assert len(s.samples) == len(SIGNAL)


def test_unknown_chunks_and_odd_padding_are_skipped():
    data = pcm_wav(SIGNAL, 22050)
    at = data.index(b"data")
    padded = data[:at] + b"LIST" + (3).to_bytes(4, "little") + b"abc\0" + data[at:]
    assert len(read_wav_bytes(padded, "p.wav").samples) == len(SIGNAL)


# ---------------------------------------------------------------------- refused, by name

SAMPLE = bytes(400)


@pytest.mark.parametrize(
    "data, why",
    [
        (b"", "too short"),
        (b"hello, this is not audio at all", "not a WAV"),
        (wav(SAMPLE, 22050, 1, 16)[:30], "no data chunk|chunk says|shorter"),
        (wav(SAMPLE, 22050, 0, 16), "0 channels"),
        (wav(SAMPLE, 22050, 9, 16), "9 channels"),
        (wav(SAMPLE, 1000, 1, 16), "1000 Hz"),
        (wav(SAMPLE, 400000, 1, 16), "400000 Hz"),
        (wav(SAMPLE, 22050, 1, 12), "12-bit"),
        (wav(SAMPLE, 22050, 1, 16, tag=2), "format tag 0x0002"),
        (wav(SAMPLE, 22050, 1, 16, tag=3), "16-bit float"),
        (wav(SAMPLE, 22050, 1, 16, data_size=100000), "truncated"),
        (float_wav(np.array([0.0, np.nan, 0.0]), 22050), "NaN"),
        (b"RIFF\x04\0\0\0WAVEdata\0\0\0\0", "before the fmt"),
        (b"RIFF\x04\0\0\0WAVEfmt \xff\xff\xff\x00", "chunk says"),
    ],
)
def test_a_broken_wav_is_refused_by_name(data, why):
    with pytest.raises(NarrationError, match=f"^broken.wav: .*({why})"):
        read_wav_bytes(data, "broken.wav")


def test_a_block_align_that_does_not_match_is_refused():
    data = bytearray(wav(SAMPLE, 22050, 2, 16))
    data[32:34] = (3).to_bytes(2, "little")
    with pytest.raises(NarrationError, match="block align 3"):
        read_wav_bytes(bytes(data), "b.wav")


def test_a_long_header_is_refused_before_decoding():
    three_hours = 3 * 3600 * 22050 * 2
    data = wav(SAMPLE, 22050, 1, 16, data_size=three_hours)
    with pytest.raises(NarrationError, match="long.wav: its header says 3:00:00"):
        read_wav_bytes(data, "long.wav", max_seconds=120)


# ---------------------------------------------------------------------- resampling


@pytest.mark.parametrize("rate", [8000, 16000, 22050, 44100, 48000, 96000, 192000])
def test_a_440_hz_tone_stays_440_hz_at_any_rate(rate):
    s = read_wav_bytes(pcm_wav(sine(440, 1.0, rate), rate), "tone.wav")
    assert abs(len(s.samples) - RATE) <= 1
    assert peak_hz(s.samples[1000:-1000], RATE) == pytest.approx(440, abs=0.5)
    # and its level: the filter's passband is flat at 440 Hz
    rms = np.sqrt(np.mean(s.samples[1000:-1000].astype(np.float64) ** 2)) / 32768
    assert rms == pytest.approx(0.5 / np.sqrt(2), rel=0.02)


def test_a_tone_above_the_new_nyquist_does_not_fold_back():
    """15 kHz at 48 kHz would alias to 7.05 kHz at 22.05 kHz without the low-pass."""
    s = read_wav_bytes(pcm_wav(sine(15000, 1.0, 48000), 48000), "high.wav")
    rms = np.sqrt(np.mean(s.samples[1000:-1000].astype(np.float64) ** 2)) / 32768
    assert rms < 0.5 / np.sqrt(2) * 10 ** (-50 / 20)  # at least 50 dB down


def test_the_wav_this_module_writes_is_the_exhibit_format():
    data = wav_bytes(silence(0.01))
    assert data[:4] == b"RIFF" and int.from_bytes(data[24:28], "little") == RATE
