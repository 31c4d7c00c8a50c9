"""The exhibit's one audio format: mono int16 at :data:`RATE`, and what is done with it.

One format everywhere means a recording is converted once, when it is loaded, and mixing,
timing and writing a track never convert again. 22.05 kHz is espeak-ng's own rate and carries
speech (below 8 kHz) with room to spare, at half the memory of 44.1 kHz.
"""

from __future__ import annotations

import io
import wave
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Sequence

import numpy as np

from exhibit.narration.errors import NarrationError
from exhibit.narration.resample import resample
from exhibit.narration.wav import WavProblem, decode
from exhibit.schema import files

RATE = 22050  # Hz, mono int16 everywhere inside the exhibit


@dataclass(frozen=True, eq=False)
class Sound:
    """Mono int16 samples at RATE, read-only (a sound is shared by the cache, the player and
    the mixer; none may change it under the others)."""

    samples: np.ndarray

    def __post_init__(self) -> None:
        samples = np.asarray(self.samples)
        if samples.dtype != np.int16 or samples.ndim != 1:
            raise ValueError(f"a Sound is 1-D int16, got {samples.ndim}-D {samples.dtype}")
        if samples.flags.writeable or not samples.flags.c_contiguous:
            samples = np.array(samples, dtype=np.int16)
            samples.flags.writeable = False
        object.__setattr__(self, "samples", samples)

    @property
    def duration(self) -> float:
        """Seconds."""
        return len(self.samples) / RATE


def _frames(seconds: float) -> int:
    return max(0, int(round(seconds * RATE)))


def silence(seconds: float) -> Sound:
    return Sound(np.zeros(_frames(seconds), dtype=np.int16))


def concatenate(sounds: Sequence[Sound], gap_s: float = 0.3) -> Sound:
    """The sounds one after another, ``gap_s`` of silence between each two (none at the ends)."""
    parts: list[np.ndarray] = []
    gap = np.zeros(_frames(gap_s), dtype=np.int16)
    for i, sound in enumerate(sounds):
        if i:
            parts.append(gap)
        parts.append(sound.samples)
    return Sound(np.concatenate(parts) if parts else np.zeros(0, dtype=np.int16))


def mix(placed: Sequence[tuple[float, Sound]], duration: float) -> Sound:
    """``duration`` seconds with each sound starting at its time (seconds; what falls before 0
    or after the end is cut off), overlaps added and saturated at the int16 limits rather than
    wrapped (a wrapped sample is a loud click)."""
    total = _frames(duration)
    acc = np.zeros(total, dtype=np.int32)
    for start, sound in placed:
        begin = int(round(start * RATE))
        samples = sound.samples
        if begin < 0:
            samples, begin = samples[-begin:], 0
        end = min(total, begin + len(samples))
        if end > begin:
            acc[begin:end] += samples[: end - begin]
    return Sound(np.clip(acc, -32768, 32767).astype(np.int16))


def to_sound(mono: np.ndarray) -> Sound:
    """Float samples in [-1, 1] at RATE as a Sound (rounded, saturated)."""
    scaled = np.rint(np.asarray(mono, dtype=np.float32) * 32768.0)
    return Sound(np.clip(scaled, -32768, 32767).astype(np.int16))


def wav_bytes(sound: Sound) -> bytes:
    """The sound as a 16-bit mono PCM WAV file."""
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(sound.samples.astype("<i2").tobytes())
    return out.getvalue()


def write_wav(path: Path, sound: Sound) -> None:
    """Write ``sound`` as a WAV file, atomically (a reader never sees half of it)."""
    files.write_atomic(path, wav_bytes(sound))


def read_wav_bytes(data: bytes, name: str, max_seconds: float | None = None) -> Sound:
    """A PCM WAV file's bytes (8/16/24/32-bit integer or 32/64-bit float, 1-8 channels, 8-192
    kHz) as a Sound: channels mixed down, rate converted. NarrationError "NAME: why" for
    anything else; ``max_seconds`` refuses a longer file from its header, before decoding."""
    try:
        mono, rate = decode(data, max_seconds)
    except WavProblem as exc:
        raise NarrationError(f"{name}: {exc}") from None
    return to_sound(resample(mono, rate, RATE))
