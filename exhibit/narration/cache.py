"""Synthesised speech on disk, so the kiosk speaks without running espeak-ng in front of a visitor.

An entry is a WAV file (a curator can play it) named by the sha256 of what makes the speech:
the engine, its version, the voice, the rate and the text, so a new espeak-ng or a changed text
misses. As with meshes (exhibit/scenes/cache.py), nothing read back is trusted: an entry is read
only as a regular file (never through a link, a FIFO or a device) of bounded size, and used only
if it is exactly the format the exhibit writes and carries its own key, the hash of its samples
and their HMAC-SHA256 under the exhibit's secret key (exhibit.narration.cache_secret: a file in
the state folder that only the exhibit's user can read) in an "xnar" chunk; anything else, a
forgery with a matching plain hash included, costs a warning naming the entry and a fresh
synthesis that replaces it. Without a usable secret key the cache is neither read nor written.
The folder is $EXHIBIT_CACHE_DIR/speech (the deployed kiosk's cache), else
$XDG_CACHE_HOME/exhibit/speech, else ~/.cache/exhibit/speech.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import struct
from pathlib import Path

import numpy as np

from exhibit.narration.cache_secret import load_key
from exhibit.narration.sound import RATE, Sound, wav_bytes
from exhibit.narration.speech import (
    ENGINE,
    MAX_OUTPUT_BYTES,
    SpeechBudget,
    engine_version,
    synthesise,
    voice_for,
)
from exhibit.narration.wav import read_header
from exhibit.schema import files

log = logging.getLogger(__name__)
_CHUNK = b"xnar"
#: What an entry's HMAC covers, before its key and samples (a new layout gets a new label).
_MAC_LABEL = b"exhibit speech cache v1\0"


def speech_cache_dir() -> Path:
    if os.environ.get("EXHIBIT_CACHE_DIR"):
        return Path(os.environ["EXHIBIT_CACHE_DIR"]) / "speech"
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "exhibit" / "speech"


def speech_key(
    text: str, language: str, rate_wpm: int | None = None, budget: SpeechBudget | None = None
) -> str:
    """The sha256 naming the speech of ``text`` in ``language``'s voice at ``rate_wpm`` (default:
    the voice's rate); raises NarrationError without espeak-ng, for a language with no voice, or
    when espeak-ng does not tell its version within ``budget``."""
    voice = voice_for(language)
    description = json.dumps(
        {
            "engine": ENGINE,
            "version": engine_version(budget),
            "voice": voice.name,
            "rate": int(voice.rate_wpm if rate_wpm is None else rate_wpm),
            "text": text,
        },
        sort_keys=True,
    )
    return hashlib.sha256(description.encode("utf-8")).hexdigest()


def _mac(secret: bytes, key: str, samples: bytes) -> str:
    """The HMAC-SHA256 of an entry: its key (so it cannot be moved to another name) and its
    samples, under the exhibit's ``secret``."""
    message = _MAC_LABEL + key.encode("ascii") + b"\0" + samples
    return hmac.new(secret, message, hashlib.sha256).hexdigest()


def _entry(sound: Sound, key: str, secret: bytes) -> bytes:
    """The sound as a WAV file with an "xnar" chunk after its data: the key, the sha256 of the
    data and their HMAC under ``secret`` (readers skip chunks they do not know)."""
    wav = wav_bytes(sound)
    samples = sound.samples.tobytes()
    tag = json.dumps(
        {
            "key": key,
            "sha256": hashlib.sha256(samples).hexdigest(),
            "hmac": _mac(secret, key, samples),
        }
    )
    body = tag.encode() + (b" " if len(tag) % 2 else b"")
    data = wav + _CHUNK + struct.pack("<I", len(body)) + body
    return data[:4] + struct.pack("<I", len(data) - 8) + data[8:]


def _read_entry(data: bytes, key: str, secret: bytes) -> Sound:
    """The sound of a cache entry; ValueError for anything not exactly as :func:`_entry` writes."""
    header, offset, size = read_header(data)
    if (header.rate, header.channels, header.bits, header.floating) != (RATE, 1, 16, False):
        raise ValueError(f"{header.rate} Hz, {header.channels} channels, {header.bits} bits")
    tail = data[offset + size :]
    if len(tail) < 8 or tail[:4] != _CHUNK:
        raise ValueError("no xnar chunk after the data")
    length = struct.unpack_from("<I", tail, 4)[0]
    if length != len(tail) - 8 or length > 4096:
        raise ValueError("a truncated or oversized xnar chunk")
    tag = files.loads_json(tail[8:])
    if not isinstance(tag, dict) or tag.get("key") != key:
        raise ValueError("made for another text")
    samples = np.frombuffer(data, dtype="<i2", count=size // 2, offset=offset).astype(np.int16)
    if hashlib.sha256(samples.tobytes()).hexdigest() != tag.get("sha256"):
        raise ValueError("its samples do not match their hash")
    mac = tag.get("hmac")
    if not isinstance(mac, str) or not hmac.compare_digest(
        mac.encode("utf-8", "replace"), _mac(secret, key, samples.tobytes()).encode()
    ):
        raise ValueError("its HMAC does not verify under this exhibit's key: not made here")
    if len(samples) == 0:
        raise ValueError("no samples")
    return Sound(samples)


def spoken(
    text: str,
    language: str,
    cache: Path | None = None,
    *,
    rate_wpm: int | None = None,
    budget: SpeechBudget | None = None,
    key_file: Path | None = None,
) -> Sound:
    """``text`` spoken in ``language``: from the cache folder (``cache``, else
    :func:`speech_cache_dir`) when a valid entry is there, else synthesised within ``budget``
    (the run's: exhibit.narration.speech.SpeechBudget) and stored. A bad entry is replaced; a
    cache that cannot be written only costs the synthesis next time. Entries are signed with
    the key in ``key_file`` (default: the state folder's, made when missing); a key file that
    is refused (exhibit.narration.cache_secret) leaves the cache unused: synthesised every time.
    NarrationError as :func:`~exhibit.narration.speech.synthesise` raises it."""
    folder = Path(cache) if cache is not None else speech_cache_dir()
    key = speech_key(text, language, rate_wpm, budget)  # an unknown language is refused here
    secret = load_key(key_file)  # None: refused, said once; the cache is not trusted
    if secret is None:
        return synthesise(text, language, rate_wpm, budget)
    path = folder / f"{language}-{key[:32]}.wav"
    try:
        data = files.read_regular(path, MAX_OUTPUT_BYTES + 8192, follow=False)
        return _read_entry(data, key, secret)
    except (FileNotFoundError, NotADirectoryError):
        pass
    except (OSError, ValueError) as exc:
        log.warning("speech cache %s is unusable (%s); speaking it again", path, exc)
    sound = synthesise(text, language, rate_wpm, budget)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        files.write_atomic(path, _entry(sound, key, secret), heal=True)
    except OSError as exc:
        log.warning("could not write the speech cache %s: %s", path, exc)
    return sound
