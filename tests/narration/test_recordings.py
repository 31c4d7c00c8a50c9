"""A curator's recordings are untrusted files: each hostile one is refused with a message that
names it, and a good one in any accepted rate and channel count is converted."""

from __future__ import annotations

import os

import numpy as np
import pytest

from exhibit.narration import RATE, NarrationError, load_recording
from exhibit.narration import recordings
from tests.narration.support import pcm_wav, peak_hz, sine, wav


@pytest.fixture
def root(tmp_path):
    folder = tmp_path / "timelines"
    folder.mkdir()
    return folder


def refused(path, root, why):
    with pytest.raises(NarrationError) as info:
        load_recording(path, root)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    assert why in message, message
    return message


def test_a_good_recording_is_converted(root):
    stereo = np.stack([sine(440, 2.0, 48000), sine(440, 2.0, 48000)], axis=1)
    path = root / "narration" / "welcome.en.wav"
    path.parent.mkdir()
    path.write_bytes(pcm_wav(stereo, 48000, 24))
    sound = load_recording(path, root)
    assert sound.duration == pytest.approx(2.0, abs=1e-3)
    assert peak_hz(sound.samples, RATE) == pytest.approx(440, abs=0.5)
    # a name relative to the root, and a link inside the root, are fine too
    assert load_recording(path.relative_to(root), root).duration == sound.duration
    (root / "link.wav").symlink_to(path)
    assert load_recording(root / "link.wav", root).duration == sound.duration


def test_missing(root):
    refused(root / "nope.wav", root, "no such file")


def test_not_audio(root):
    (root / "notes.wav").write_text("these are my notes, not a recording\n")
    refused(root / "notes.wav", root, "not a WAV")


def test_truncated_header(root):
    (root / "cut.wav").write_bytes(pcm_wav(sine(440, 1, 22050), 22050)[:30])
    refused(root / "cut.wav", root, "truncated")


def test_truncated_data(root):
    (root / "cut.wav").write_bytes(pcm_wav(sine(440, 1, 22050), 22050)[:5000])
    refused(root / "cut.wav", root, "truncated")


def test_huge(root):
    with open(root / "huge.wav", "wb") as f:
        f.truncate(recordings.MAX_BYTES + 1)  # sparse: no disk, no time
    refused(root / "huge.wav", root, "too large")


def test_fifo(root):
    os.mkfifo(root / "pipe.wav")
    refused(root / "pipe.wav", root, "a FIFO")


def test_a_folder(root):
    (root / "folder.wav").mkdir()
    refused(root / "folder.wav", root, "a folder")


def test_a_symlink_out_of_the_root(root, tmp_path):
    outside = tmp_path / "secret.wav"
    outside.write_bytes(pcm_wav(sine(440, 1, 22050), 22050))
    (root / "escape.wav").symlink_to(outside)
    refused(root / "escape.wav", root, "outside")
    refused(root / ".." / "secret.wav", root, "outside")


def test_dev_zero(root):
    (root / "zero.wav").symlink_to("/dev/zero")
    refused(root / "zero.wav", root, "outside")
    refused("/dev/zero", "/dev", "a character device")


@pytest.mark.parametrize(
    "header, why",
    [
        (dict(channels=0), "0 channels"),
        (dict(channels=9), "9 channels"),
        (dict(rate=1000), "1000 Hz"),
    ],
)
def test_a_format_that_cannot_be_converted(root, header, why):
    fields = dict(rate=22050, channels=1, bits=16) | header
    (root / "odd.wav").write_bytes(wav(bytes(4000), **fields))
    refused(root / "odd.wav", root, why)


def test_three_hours_long_per_header(root):
    three_hours = 3 * 3600 * 22050 * 2
    (root / "long.wav").write_bytes(wav(bytes(4000), 22050, 1, 16, data_size=three_hours))
    refused(root / "long.wav", root, "3:00:00")


def test_longer_than_the_limit_in_a_streaming_header(root, monkeypatch):
    monkeypatch.setattr(recordings, "MAX_SECONDS", 1.0)
    data = pcm_wav(sine(440, 1.5, 8000), 8000)
    raw = data[data.index(b"data") + 8 :]
    (root / "stream.wav").write_bytes(wav(raw, 8000, 1, 16, data_size=0xFFFFFFFF))
    refused(root / "stream.wav", root, "over the 1 s limit")


def test_silent(root):
    (root / "quiet.wav").write_bytes(pcm_wav(np.zeros(22050), 22050))
    refused(root / "quiet.wav", root, "silent")
    (root / "hum.wav").write_bytes(pcm_wav(sine(50, 1, 22050, amplitude=0.0005), 22050))
    refused(root / "hum.wav", root, "silent")


def test_empty(root):
    (root / "empty.wav").write_bytes(pcm_wav(np.zeros(0), 22050))
    refused(root / "empty.wav", root, "no audio")


def test_shorter_than_a_word(root):
    """A 1-sample file (an export gone wrong) was accepted and "played"."""
    (root / "click.wav").write_bytes(pcm_wav(np.full(1, 20000), 22050))
    refused(root / "click.wav", root, "under the 0.2 s a word takes")
    (root / "word.wav").write_bytes(pcm_wav(sine(440, 0.25, 22050), 22050))
    assert load_recording(root / "word.wav", root).duration == pytest.approx(0.25, abs=1e-3)
