"""Playback: the callback's generator and feed tested directly (no clock), and the Player on
miniaudio's null backend, which takes samples in real time as a sound card would; a device that
does not exist is "absent", never an exception."""

from __future__ import annotations

import time

import numpy as np
import pytest

from exhibit.narration import RATE, Player, Sound, silence
from exhibit.narration import player as player_module
from exhibit.narration.feed import MAX_VOLUME, Feed, clamp_volume, stream

#: How long a poll may wait for what the null device does in real time (generous: CI is slow).
BOUND_S = 20.0


def ramp(n: int) -> Sound:
    return Sound(np.arange(1, n + 1, dtype=np.int16))


def started(feed: Feed):
    gen = stream(feed)
    assert next(gen) == b""
    return gen


def frames(data: bytes) -> np.ndarray:
    return np.frombuffer(data, dtype=np.int16)


def test_the_stream_plays_the_sound_then_silence():
    feed = Feed(volume=1.0)
    gen = started(feed)
    assert not frames(gen.send(4)).any()  # nothing loaded: silence
    feed.load(ramp(10))
    assert feed.playing
    assert list(frames(gen.send(4))) == [1, 2, 3, 4]
    assert list(frames(gen.send(4))) == [5, 6, 7, 8]
    assert list(frames(gen.send(4))) == [9, 10, 0, 0]
    assert feed.playing  # the last samples are with the device, not yet heard
    assert not frames(gen.send(4)).any()
    assert not feed.playing


def test_the_tap_counts_what_the_device_took():
    """Only frames of sound count, and a sound counts once it has begun, not when loaded."""
    feed = Feed(volume=1.0)
    gen = started(feed)
    gen.send(8)
    assert (feed.sounds_begun, feed.frames_played) == (0, 0)
    feed.load(ramp(10))
    assert feed.sounds_begun == 0
    gen.send(4)
    gen.send(8)
    gen.send(8)
    assert (feed.sounds_begun, feed.frames_played) == (1, 10)
    feed.load(ramp(3))
    feed.clear()
    gen.send(4)
    assert (feed.sounds_begun, feed.frames_played) == (1, 10)


def test_play_replaces_and_stop_silences():
    feed = Feed(volume=1.0)
    gen = started(feed)
    feed.load(ramp(100))
    gen.send(10)
    feed.load(ramp(3))
    assert list(frames(gen.send(5))) == [1, 2, 3, 0, 0]
    feed.load(ramp(100))
    feed.clear()
    assert not feed.playing and not frames(gen.send(5)).any()


def test_volume_scales_and_is_clamped():
    feed = Feed(volume=0.5)
    gen = started(feed)
    feed.load(Sound(np.array([1000, -32768, 32767], dtype=np.int16)))
    assert list(frames(gen.send(3))) == [500, -16384, 16384]
    assert clamp_volume(5.0) == MAX_VOLUME == 1.0
    assert clamp_volume(-1) == 0.0
    assert clamp_volume(float("nan")) == clamp_volume("loud") == 0.8  # type: ignore[arg-type]


def test_the_stream_survives_a_failing_feed(monkeypatch):
    feed = Feed()
    gen = started(feed)
    monkeypatch.setattr(feed, "take", lambda n: 1 / 0)
    assert gen.send(8) == bytes(16)


def test_every_request_is_answered_with_exactly_its_frames():
    feed = Feed()
    gen = started(feed)
    feed.load(ramp(1000))
    for n in (1, 7, 441, 0, 1024):
        assert len(gen.send(n)) == 2 * n
    before = feed.last_request
    gen.send(1)
    assert feed.last_request >= before


def wait_for(condition, bound=BOUND_S):
    deadline = time.monotonic() + bound
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def test_the_null_backend_plays_stops_and_reports():
    with Player(backend="null", volume=0.5) as player:
        status = player.status()
        assert status["state"] == "ok" and status["error"] is None and status["device"]
        assert not player.playing
        player.play(silence(0.2))
        assert player.playing
        assert wait_for(lambda: not player.playing)  # the null device ate it in real time
        player.play(silence(60))
        assert player.playing
        player.stop()
        assert not player.playing
        assert player.status()["state"] == "ok"
        assert player.volume == 0.5


def test_play_returns_at_once():
    long = Sound(np.zeros(120 * RATE, dtype=np.int16))
    with Player(backend="null") as player:
        began = time.perf_counter()
        for _ in range(100):
            player.play(long)
        each = (time.perf_counter() - began) / 100
    assert each < 0.005, f"play() took {each * 1000:.2f} ms"


def test_a_device_that_does_not_exist_is_absent():
    player = Player(device="Speaker That Is Not There", backend="null")
    status = player.status()
    assert status["state"] == "absent"
    assert "Speaker That Is Not There" in status["error"]
    player.play(silence(1))
    assert not player.playing
    player.stop()
    player.close()
    player.close()


def test_a_named_device_is_found():
    with Player(device="null playback", backend="null") as player:
        status = player.status()
        assert (status["state"], status["device"], status["error"]) == (
            "ok",
            "NULL Playback Device",
            None,
        )


def test_an_unknown_backend_is_an_error_not_an_exception():
    player = Player(backend="gramophone")
    assert player.status()["state"] == "error"
    assert "gramophone" in player.status()["error"]
    player.play(silence(1))
    assert not player.playing


def test_a_speaker_plugged_back_in_is_found_on_the_next_play(monkeypatch):
    real_find = player_module._find
    monkeypatch.setattr(player_module, "_find", lambda playbacks, wanted: None)
    player = Player(device="NULL Playback Device", backend="null")
    assert player.status()["state"] == "absent"
    monkeypatch.setattr(player_module, "_find", real_find)
    monkeypatch.setattr(player_module, "RETRY_S", 0.0)
    player.play(silence(1))  # no-op, and a reopen in the background
    assert not player.playing
    assert wait_for(lambda: player.status()["state"] == "ok")
    player.play(silence(1))
    assert player.playing
    player.close()


def test_retries_are_spaced(monkeypatch):
    player = Player(device="nothing", backend="null")
    opened = []
    monkeypatch.setattr(player, "_open", lambda: opened.append(1))
    monkeypatch.setattr(player_module, "RETRY_S", 3600.0)
    for _ in range(10):
        player.play(silence(1))
    assert opened == []
    player.close()


def test_a_device_that_stops_taking_samples_is_noticed_and_reopened(monkeypatch):
    with Player(backend="null") as player:
        player.play(silence(60))
        player._feed.last_request -= 3600  # as if the callback had not run for an hour
        assert not player.playing
        status = player.status()
        assert status["state"] == "error" and "stopped taking samples" in status["error"]
        monkeypatch.setattr(player_module, "RETRY_S", 0.0)
        player.play(silence(60))
        assert wait_for(lambda: player.status()["state"] == "ok")


def test_after_close_nothing_plays():
    player = Player(backend="null")
    player.close()
    player.play(silence(1))
    assert not player.playing
    assert player.status()["state"] != "ok"


@pytest.mark.parametrize("volume", [-3, 0, 0.3, 7, float("inf")])
def test_the_volume_never_exceeds_the_maximum(volume):
    player = Player(backend="null", volume=volume)
    assert 0 <= player.volume <= MAX_VOLUME
    player.close()


def test_a_process_with_a_player_left_open_still_exits():
    """miniaudio closing a device while the interpreter shuts down hung `exhibit render` at
    exit (0 % CPU, for ever): open players are closed at exit instead."""
    import subprocess
    import sys

    script = (
        "from exhibit.narration.player import Player\n"
        "from exhibit.narration.sound import silence\n"
        "p = Player(backend='null')\n"
        "p.play(silence(5.0))\n"
        "print('playing', p.playing)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0 and "playing" in result.stdout, result.stderr


def test_alsa_says_nothing_of_its_own_when_no_card_opens():
    """Each open attempt on a machine without a sound card made libasound print about 35
    "ALSA lib ... cannot find card" lines (the journal, at every retry); the player's own
    status line says why in one."""
    import ctypes.util
    import subprocess
    import sys

    if ctypes.util.find_library("asound") is None:
        pytest.skip("libasound is not installed (Debian: libasound2)")
    probe = (
        "from exhibit.narration import Player\n"
        "p = Player(backend='alsa'); p.close(); p = Player(backend='alsa'); p.close()\n"
    )
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "ALSA lib" not in result.stderr, result.stderr[:2000]
