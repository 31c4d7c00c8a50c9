"""What the audio callback plays: the current sound and how far it has got, shared with the frame
loop under a lock held only for a slice (microseconds), so neither side ever waits on the other.

The device runs all the time and the callback asks for frames whether or not anything plays
(silence then), so starting a sound is swapping a reference, and a device that stops asking
(unplugged, its thread dead) shows as a request that is late: :attr:`Feed.last_request`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Generator

import numpy as np

from exhibit.narration.sound import Sound

#: The loudest the exhibit plays: unity gain, so a sample is never scaled past full scale and
#: the loudness a visitor hears is set once, by the amplifier, where a technician can limit it.
MAX_VOLUME = 1.0
DEFAULT_VOLUME = 0.8


def clamp_volume(volume: float) -> float:
    """``volume`` in [0, MAX_VOLUME]; anything that is not a finite number is the default."""
    try:
        value = float(volume)
    except (TypeError, ValueError):
        return DEFAULT_VOLUME
    if not math.isfinite(value):
        return DEFAULT_VOLUME
    return min(MAX_VOLUME, max(0.0, value))


class Feed:
    """The sound being played, its position, and the volume, for one callback thread."""

    def __init__(self, volume: float = DEFAULT_VOLUME):
        self._lock = threading.Lock()
        self._samples: np.ndarray | None = None
        self._position = 0
        self.volume = clamp_volume(volume)
        #: time.monotonic() of the callback's last request for frames.
        self.last_request = time.monotonic()
        #: The tap: frames of sound (not silence) the device has taken, and how many sounds it
        #: began, counted in the device's own thread, so they show what really went out (the
        #: health file's proof that narration sounds, on the null device of a test too).
        self.frames_played = 0
        self.sounds_begun = 0

    def load(self, sound: Sound) -> None:
        """Play ``sound`` from its start, replacing whatever played."""
        with self._lock:
            self._samples = sound.samples if len(sound.samples) else None
            self._position = 0

    def clear(self) -> None:
        with self._lock:
            self._samples = None
            self._position = 0

    @property
    def playing(self) -> bool:
        """True until the callback has asked for more after the last sample was handed over."""
        return self._samples is not None

    def take(self, frames: int) -> bytes:
        """The next ``frames`` frames as int16 bytes, silence after the end of the sound."""
        with self._lock:
            self.last_request = time.monotonic()
            samples = self._samples
            if samples is not None:
                chunk = samples[self._position : self._position + frames]
                if self._position == 0 and len(chunk):
                    self.sounds_begun += 1
                self._position += len(chunk)
                self.frames_played += len(chunk)
                if len(chunk) == 0:
                    self._samples = None
            volume = self.volume
        out = np.zeros(max(0, frames), dtype=np.int16)
        if samples is not None and len(chunk):
            scaled = chunk.astype(np.float32) * volume
            out[: len(chunk)] = np.clip(np.rint(scaled), -32768, 32767).astype(np.int16)
        return out.tobytes()


def stream(feed: Feed) -> Generator[bytes, int, None]:
    """The generator miniaudio's callback drives: sent a frame count, it yields that many
    frames of mono int16 (primed with one next() before the device starts). It never ends and
    never raises, so the device never stops on its own."""
    frames = yield b""
    while True:
        try:
            data = feed.take(int(frames))
        except Exception:  # noqa: BLE001 - a raise would stop the device for good
            data = bytes(2 * max(0, int(frames or 0)))
        frames = yield data
