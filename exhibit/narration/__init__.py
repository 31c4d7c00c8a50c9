"""Narration: the spoken track of a timeline (issue 35), as sounds the kiosk and the renderer use.

Everything inside the exhibit is mono 16-bit audio at one rate (:mod:`.sound`), so mixing, timing
and writing never convert. Speech comes from espeak-ng offline (:mod:`.speech`), cached like
meshes (:mod:`.cache`); a curator's recordings are untrusted files, checked and converted
(:mod:`.recordings`); :mod:`.player` plays from miniaudio's callback thread, so a frame never
waits for audio and a missing speaker never stops the kiosk.
"""

from __future__ import annotations

from exhibit.narration.cache import spoken
from exhibit.narration.errors import NarrationError
from exhibit.narration.player import Player
from exhibit.narration.recordings import load_recording
from exhibit.narration.sound import (
    RATE,
    Sound,
    concatenate,
    mix,
    read_wav_bytes,
    silence,
    write_wav,
)
from exhibit.narration.speech import (
    ENGINE,
    SpeechBudget,
    SpeechSkipped,
    Voice,
    available,
    engine_version,
    synthesise,
    voice_for,
)

__all__ = [
    "ENGINE",
    "NarrationError",
    "Player",
    "RATE",
    "Sound",
    "SpeechBudget",
    "SpeechSkipped",
    "Voice",
    "available",
    "concatenate",
    "engine_version",
    "load_recording",
    "mix",
    "read_wav_bytes",
    "silence",
    "spoken",
    "synthesise",
    "voice_for",
    "write_wav",
]
