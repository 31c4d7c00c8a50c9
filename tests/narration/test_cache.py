"""The speech cache: a hit is read back, a miss is spoken and stored, and an entry that is
corrupt, truncated, made for another text or not a file at all is spoken again and replaced,
never trusted and never a crash. The engine is faked (fast, and the same with or without
espeak-ng); one test at the end uses the real one."""

from __future__ import annotations

import logging
import os

import numpy as np
import pytest

from exhibit.narration import NarrationError, Sound, available, cache, spoken


@pytest.fixture
def engine(monkeypatch):
    """A fake espeak-ng: each text's samples derive from it; ``calls`` counts syntheses."""
    calls: list[tuple[str, str, int]] = []

    def synthesise(text, language, rate_wpm=150, budget=None):
        calls.append((text, language, rate_wpm))
        rng = np.random.default_rng(abs(hash((text, language))) % (1 << 32))
        return Sound(rng.integers(-20000, 20000, 2205 + len(text), dtype=np.int16))

    monkeypatch.setattr(cache, "synthesise", synthesise)
    monkeypatch.setattr(cache, "engine_version", lambda budget=None: "9.99")
    return calls


def entries(folder):
    return sorted(p for p in os.listdir(folder) if not p.startswith("."))


def test_a_miss_then_a_hit(tmp_path, engine):
    first = spoken("The torus turns.", "en", tmp_path)
    assert len(engine) == 1 and len(entries(tmp_path)) == 1
    again = spoken("The torus turns.", "en", tmp_path)
    assert len(engine) == 1
    assert np.array_equal(first.samples, again.samples)
    spoken("Der Torus dreht sich.", "de", tmp_path)
    spoken("The torus turns.", "en", tmp_path, rate_wpm=180)
    assert len(engine) == 3 and len(entries(tmp_path)) == 3


def test_a_new_engine_version_misses(tmp_path, engine, monkeypatch):
    spoken("Hello", "en", tmp_path)
    monkeypatch.setattr(cache, "engine_version", lambda budget=None: "10.0")
    spoken("Hello", "en", tmp_path)
    assert len(engine) == 2


def only_entry(folder):
    (name,) = entries(folder)
    return folder / name


@pytest.mark.parametrize(
    "spoil",
    [
        pytest.param(lambda data: b"garbage" * 100, id="garbage"),
        pytest.param(lambda data: data[: len(data) // 2], id="truncated"),
        pytest.param(lambda data: data[:40], id="header only"),
        pytest.param(lambda data: b"", id="empty"),
        pytest.param(lambda data: data[:-10] + b"\0" * 10, id="tag damaged"),
        pytest.param(
            lambda data: data[:100] + bytes([data[100] ^ 0xFF]) + data[101:], id="a sample flipped"
        ),
    ],
)
def test_a_corrupt_entry_is_spoken_again_and_replaced(tmp_path, engine, spoil, caplog):
    good = spoken("Hello", "en", tmp_path)
    path = only_entry(tmp_path)
    data = path.read_bytes()
    path.write_bytes(spoil(data))
    with caplog.at_level(logging.WARNING):
        again = spoken("Hello", "en", tmp_path)
    assert np.array_equal(again.samples, good.samples)
    assert len(engine) == 2
    assert "unusable" in caplog.text or spoil(data) == b""
    assert path.read_bytes() == data  # rewritten whole
    spoken("Hello", "en", tmp_path)
    assert len(engine) == 2


def test_an_entry_for_another_text_is_not_trusted(tmp_path, engine):
    spoken("Hello", "en", tmp_path)
    spoken("Goodbye", "en", tmp_path)
    hello, goodbye = (tmp_path / n for n in entries(tmp_path))
    hello.write_bytes(goodbye.read_bytes())  # a valid entry, copied over the wrong name
    spoken("Hello", "en", tmp_path)
    spoken("Goodbye", "en", tmp_path)
    assert len(engine) == 3


def test_a_plain_wav_of_the_right_name_is_not_trusted(tmp_path, engine):
    spoken("Hello", "en", tmp_path)
    path = only_entry(tmp_path)
    from exhibit.narration.sound import wav_bytes

    path.write_bytes(wav_bytes(Sound(np.ones(100, dtype=np.int16))))
    assert len(spoken("Hello", "en", tmp_path).samples) > 100
    assert len(engine) == 2


@pytest.mark.parametrize("kind", ["fifo", "dev-zero link", "folder"])
def test_something_other_than_a_file_in_its_place_is_replaced(tmp_path, engine, kind):
    spoken("Hello", "en", tmp_path)
    path = only_entry(tmp_path)
    path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dev-zero link":
        path.symlink_to("/dev/zero")
    else:
        path.mkdir()
    spoken("Hello", "en", tmp_path)
    assert len(engine) == 2
    assert path.is_file() and not path.is_symlink()


def test_a_cache_that_cannot_be_written_costs_only_the_synthesis(tmp_path, engine):
    blocked = tmp_path / "file-in-the-way"
    blocked.write_text("x")
    assert spoken("Hello", "en", blocked).duration > 0
    assert spoken("Hello", "en", blocked).duration > 0
    assert len(engine) == 2


def test_an_unknown_language_is_refused_before_anything_is_read(tmp_path, engine):
    with pytest.raises(NarrationError, match="no espeak-ng voice for language '../x'"):
        spoken("Hello", "../x", tmp_path)
    assert entries(tmp_path) == [] and engine == []


def test_the_cache_folder(monkeypatch, tmp_path):
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "meshes"))
    assert cache.speech_cache_dir() == tmp_path / "meshes" / "speech"
    monkeypatch.delenv("EXHIBIT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.speech_cache_dir() == tmp_path / "xdg" / "exhibit" / "speech"


@pytest.mark.skipif(not available(), reason="espeak-ng is not installed (bootstrap.sh installs it)")
def test_with_the_real_engine(tmp_path):
    first = spoken("Welcome to the fourth dimension.", "en", tmp_path)
    second = spoken("Welcome to the fourth dimension.", "en", tmp_path)
    assert first.duration > 1 and np.array_equal(first.samples, second.samples)
