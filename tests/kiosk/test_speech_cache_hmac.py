"""The speech cache cannot be forged from outside the exhibit's state (issue 42, item 5).

An entry's name and plain hash come from public facts, so a self-consistent forgery (a 440 Hz
tone carrying its own key and the sha256 of its samples) used to be played wherever the speech
should be. Entries now carry an HMAC under a key in the state folder, mode 0600; a key file that
is not a private regular file of a sane size is refused (the cache is then not used), never a
hang or a crash. The engine is faked as in tests/narration/test_cache.py."""

from __future__ import annotations

import json
import logging
import os
import signal
import stat
import struct

import numpy as np
import pytest

from exhibit.commands import install as inst
from exhibit.narration import Sound, cache, cache_secret, make_cache_key, spoken
from exhibit.narration.sound import RATE, wav_bytes
from exhibit.operations import health


@pytest.fixture(autouse=True)
def state(tmp_path, monkeypatch):
    """A fresh state folder (where the key is made) for each test, and no earlier warnings."""
    folder = tmp_path / "state"
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(folder))
    monkeypatch.setattr(cache_secret, "_warned", set(), raising=False)
    return folder


@pytest.fixture(autouse=True)
def no_hang():
    """A key file that blocks a read (a FIFO) must not hang the test run: 10 s at most."""

    def expired(signum, frame):
        raise TimeoutError("hung reading the key file")

    old = signal.signal(signal.SIGALRM, expired)
    signal.alarm(10)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.fixture
def engine(monkeypatch):
    """A fake espeak-ng: noise derived from the text; ``calls`` counts syntheses."""
    calls: list[str] = []

    def synthesise(text, language, rate_wpm=150, budget=None):
        calls.append(text)
        rng = np.random.default_rng(abs(hash((text, language))) % (1 << 32))
        return Sound(rng.integers(-20000, 20000, 4410 + len(text), dtype=np.int16))

    monkeypatch.setattr(cache, "synthesise", synthesise)
    monkeypatch.setattr(cache, "engine_version", lambda budget=None: "9.99")
    return calls


def entry_of(folder):
    (name,) = [n for n in os.listdir(folder) if not n.startswith(".")]
    return folder / name


def tone_entry(key: str, freq: float = 440.0, seconds: float = 1.0) -> bytes:
    """What a forger can write without the exhibit's secret: a tone as a WAV with the "xnar"
    chunk of the old format, carrying the entry's plain key and the sha256 of the tone."""
    import hashlib

    t = np.arange(int(RATE * seconds)) / RATE
    samples = np.round(12000 * np.sin(2 * np.pi * freq * t)).astype(np.int16)
    tag = json.dumps({"key": key, "sha256": hashlib.sha256(samples.tobytes()).hexdigest()})
    body = tag.encode() + (b" " if len(tag) % 2 else b"")
    data = wav_bytes(Sound(samples)) + b"xnar" + struct.pack("<I", len(body)) + body
    return data[:4] + struct.pack("<I", len(data) - 8) + data[8:]


def is_tone(sound: Sound, freq: float = 440.0) -> bool:
    spectrum = np.abs(np.fft.rfft(sound.samples.astype(np.float64)))
    return abs(int(np.argmax(spectrum)) * RATE / len(sound.samples) - freq) < 5


def test_a_self_consistent_forgery_is_rejected_and_the_speech_made_again(tmp_path, engine, caplog):
    cached = tmp_path / "cache"
    real = spoken("Welcome to the fourth dimension.", "en", cached)
    path = entry_of(cached)
    key = cache.speech_key("Welcome to the fourth dimension.", "en")  # public facts only
    assert path.name == f"en-{key[:32]}.wav"
    path.write_bytes(tone_entry(key))
    with caplog.at_level(logging.WARNING):
        again = spoken("Welcome to the fourth dimension.", "en", cached)
    assert not is_tone(again), "the forged tone was played"
    assert np.array_equal(again.samples, real.samples) and len(engine) == 2
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and str(path) in warnings[0] and "HMAC" in warnings[0]
    # replaced by a signed entry, which is a hit from now on
    assert not is_tone(spoken("Welcome to the fourth dimension.", "en", cached))
    assert len(engine) == 2
    assert b'"hmac"' in path.read_bytes()


def test_a_cache_made_under_one_key_is_not_trusted_under_another(
    tmp_path, engine, monkeypatch, caplog
):
    cached = tmp_path / "cache"
    spoken("Hello", "en", cached)
    spoken("Hello", "en", cached)
    assert len(engine) == 1
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(tmp_path / "another machine"))
    with caplog.at_level(logging.WARNING):
        spoken("Hello", "en", cached)
    assert len(engine) == 2
    assert "HMAC" in caplog.text and str(entry_of(cached)) in caplog.text
    spoken("Hello", "en", cached)  # re-signed under the new key
    assert len(engine) == 2


def test_the_key_is_made_on_first_use_in_the_state_folder_mode_0600(tmp_path, engine, state):
    spoken("Hello", "en", tmp_path / "cache")
    key = state / cache_secret.KEY_FILE
    info = os.lstat(key)
    assert stat.S_ISREG(info.st_mode) and stat.S_IMODE(info.st_mode) == 0o600
    assert info.st_uid == os.geteuid() and info.st_size == cache_secret.KEY_BYTES
    made = key.read_bytes()
    spoken("Goodbye", "en", tmp_path / "cache")
    assert key.read_bytes() == made  # made once, kept
    assert [n for n in os.listdir(state)] == [cache_secret.KEY_FILE]  # no temporary left


def test_the_key_is_made_private_whatever_the_umask(tmp_path):
    old = os.umask(0)
    try:
        cache_secret.make_key(tmp_path / "k")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "k").st_mode) == 0o600


def spoil_readable(path):
    path.write_bytes(os.urandom(32))
    path.chmod(0o644)


def spoil_group_writable(path):
    path.write_bytes(os.urandom(32))
    path.chmod(0o620)


def spoil_symlink(path):
    target = path.with_name("elsewhere.key")
    target.write_bytes(os.urandom(32))
    target.chmod(0o600)
    path.symlink_to(target)


def spoil_fifo(path):
    os.mkfifo(path, 0o600)


def spoil_dev_zero(path):
    path.symlink_to("/dev/zero")


def spoil_empty(path):
    path.touch(0o600)
    path.chmod(0o600)


def spoil_short(path):
    path.write_bytes(b"x" * 8)
    path.chmod(0o600)


def spoil_huge(path):
    path.write_bytes(b"x" * (cache_secret.MAX_KEY_BYTES + 1))
    path.chmod(0o600)


def spoil_folder(path):
    path.mkdir(mode=0o700)


BAD_KEYS = {
    "world readable": (spoil_readable, "mode 0644"),
    "group writable": (spoil_group_writable, "mode 0620"),
    "a symlink to a private file": (spoil_symlink, "symbolic link"),
    "a FIFO": (spoil_fifo, "not a regular file"),
    "a link to /dev/zero": (spoil_dev_zero, "symbolic link"),
    "empty": (spoil_empty, "0 bytes"),
    "short": (spoil_short, "8 bytes"),
    "oversized": (spoil_huge, f"{cache_secret.MAX_KEY_BYTES + 1} bytes"),
    "a folder": (spoil_folder, "not a regular file"),
}


@pytest.mark.parametrize("kind", list(BAD_KEYS))
def test_a_bad_key_file_is_refused_and_the_cache_not_trusted(tmp_path, engine, state, kind, caplog):
    spoil, why = BAD_KEYS[kind]
    cached = tmp_path / "cache"
    state.mkdir()
    key = state / cache_secret.KEY_FILE
    spoil(key)
    before = os.lstat(key)
    with caplog.at_level(logging.WARNING):
        first = spoken("Hello", "en", cached)
        second = spoken("Hello", "en", cached)
    assert np.array_equal(first.samples, second.samples)
    assert len(engine) == 2  # synthesised each time: nothing read from the cache
    assert not cached.exists() or os.listdir(cached) == []  # nor written to it
    lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(lines) == 1, lines  # one clear line, not one per caption
    assert str(key) in lines[0] and why in lines[0] and "not trusted" in lines[0]
    after = os.lstat(key)  # left as it was for staff to look at
    assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino)


def test_a_forged_entry_is_not_played_while_the_key_is_refused(tmp_path, engine, state):
    cached = tmp_path / "cache"
    cached.mkdir()
    state.mkdir()
    spoil_readable(state / cache_secret.KEY_FILE)
    key = cache.speech_key("Hello", "en")
    (cached / f"en-{key[:32]}.wav").write_bytes(tone_entry(key))
    assert not is_tone(spoken("Hello", "en", cached))


def test_a_key_file_of_another_user_is_refused(tmp_path, state, monkeypatch):
    state.mkdir()
    key = state / cache_secret.KEY_FILE
    key.write_bytes(os.urandom(32))
    key.chmod(0o600)
    owner = os.stat(key).st_uid
    monkeypatch.setattr(cache_secret.os, "geteuid", lambda: owner + 4242)  # another user
    with pytest.raises(cache_secret.KeyRefused, match=f"owned by uid {owner}, not this user"):
        cache_secret.read_key(key)


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to give files to another user")
def test_root_gives_a_key_it_makes_to_the_owner_of_the_state_folder_and_reads_theirs(tmp_path):
    folder = tmp_path / "state"
    folder.mkdir()
    os.chown(folder, 4242, 4243)
    made = cache_secret.make_key(folder / "k")
    info = os.stat(folder / "k")
    assert (info.st_uid, info.st_gid, stat.S_IMODE(info.st_mode)) == (4242, 4243, 0o600)
    assert cache_secret.read_key(folder / "k") == made


def test_the_key_file_at_dev_zero_itself_is_refused_without_reading():
    with pytest.raises(cache_secret.KeyRefused, match="not a regular file"):
        cache_secret.read_key(cache_secret.Path("/dev/zero"))


def test_a_state_folder_that_cannot_hold_the_key_costs_only_the_synthesis(
    tmp_path, engine, monkeypatch, caplog
):
    blocked = tmp_path / "a file"
    blocked.write_text("x")
    monkeypatch.setenv("EXHIBIT_STATE_DIR", str(blocked))
    with caplog.at_level(logging.WARNING):
        assert spoken("Hello", "en", tmp_path / "cache").duration > 0
    assert "not trusted" in caplog.text and len(engine) == 1


@pytest.mark.parametrize(
    "env",
    [
        {"EXHIBIT_STATE_DIR": "/var/lib/exhibit", "HOME": "/h"},
        {"XDG_STATE_HOME": "/x", "HOME": "/h"},
        {"HOME": "/h"},
    ],
)
def test_the_key_lives_in_the_same_state_folder_as_the_health_file(env):
    assert cache_secret.state_dir(env) == health.state_dir(env)
    assert cache_secret.key_path(env) == health.state_dir(env) / "speech-cache.key"


def test_install_makes_the_key_as_the_service_user_with_its_environment():
    commands = inst.steps(need_user=True)
    folder = ["install", "-d", "-o", "exhibit", "-g", "exhibit", "-m", "0755", inst.HOME]
    make = [c for c in commands if c[-2:] == ["-m", "exhibit.narration.make_cache_key"]]
    assert folder in commands and len(make) == 1
    (make,) = make
    assert commands.index(folder) < commands.index(make)
    assert commands.index(make) < next(i for i, c in enumerate(commands) if "prepare" in c)
    assert make[:6] == ["runuser", "-u", "exhibit", "--", "env", "-i"]
    assert "EXHIBIT_STATE_DIR=/var/lib/exhibit" in make
    assert make[-4:-2] == [f"{inst.DEFAULT_PREFIX}/.venv/bin/python", "-I"]
    # an update's install builds nothing as the user: a kiosk without a key makes it itself
    assert make not in inst.steps(need_user=False, prepare=False)


def test_the_install_step_makes_a_private_key_keeps_it_and_refuses_a_bad_one(tmp_path, capsys):
    key = tmp_path / "state" / "speech-cache.key"
    assert make_cache_key.main([str(key)]) == 0
    assert stat.S_IMODE(os.stat(key).st_mode) == 0o600
    made = key.read_bytes()
    assert make_cache_key.main([str(key)]) == 0 and key.read_bytes() == made
    assert "(made, mode 0600)" in capsys.readouterr().out
    key.chmod(0o644)
    assert make_cache_key.main([str(key)]) == 1
    assert "mode 0644" in capsys.readouterr().err
