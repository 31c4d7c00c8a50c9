"""WAV files built in the tests, with numpy, wave and struct: every format the decoder accepts
and the broken ones it must refuse."""

from __future__ import annotations

import io
import struct
import wave

import numpy as np


def sine(freq: float, seconds: float, rate: int, amplitude: float = 0.5) -> np.ndarray:
    t = np.arange(int(round(seconds * rate))) / rate
    return amplitude * np.sin(2 * np.pi * freq * t)


def pcm_wav(signal: np.ndarray, rate: int, bits: int = 16) -> bytes:
    """Integer PCM through the wave module; ``signal`` is frames x channels (or 1-D), in [-1, 1]."""
    frames = np.atleast_2d(np.asarray(signal, dtype=np.float64).T).T
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(frames.shape[1])
        w.setsampwidth(bits // 8)
        w.setframerate(rate)
        w.writeframes(pcm_bytes(frames, bits))
    return out.getvalue()


def pcm_bytes(frames: np.ndarray, bits: int) -> bytes:
    full = float(1 << (bits - 1))
    ints = np.clip(np.rint(frames * full), -full, full - 1).astype(np.int64)
    if bits == 8:
        return (ints + 128).astype(np.uint8).tobytes()
    if bits == 24:
        little = ints.astype("<i4").reshape(-1, 1).view(np.uint8).reshape(-1, 4)[:, :3]
        return little.tobytes()
    return ints.astype(f"<i{bits // 8}").tobytes()


def wav(
    data: bytes,
    rate: int,
    channels: int,
    bits: int,
    tag: int = 1,
    extensible: bool = False,
    data_size: int | None = None,
) -> bytes:
    """A WAV file of ``data`` with a header written by hand (any field, right or wrong)."""
    align = channels * bits // 8
    fmt = struct.pack(
        "<HHIIHH", 0xFFFE if extensible else tag, channels, rate, rate * align, align, bits
    )
    if extensible:  # cbSize, valid bits, channel mask, sub-format GUID (tag first)
        fmt += struct.pack("<HHI", 22, bits, 0) + struct.pack("<H", tag) + bytes(14)
    size = len(data) if data_size is None else data_size
    body = b"WAVE" + b"fmt " + struct.pack("<I", len(fmt)) + fmt
    body += b"data" + struct.pack("<I", size) + data
    return b"RIFF" + struct.pack("<I", min(len(body), 0xFFFFFFFF)) + body


def float_wav(signal: np.ndarray, rate: int, bits: int = 32, extensible: bool = False) -> bytes:
    frames = np.atleast_2d(np.asarray(signal, dtype=np.float64).T).T
    data = frames.astype(f"<f{bits // 8}").tobytes()
    return wav(data, rate, frames.shape[1], bits, tag=3, extensible=extensible)


def peak_hz(samples: np.ndarray, rate: int) -> float:
    """The frequency of the strongest FFT bin (Hann window), interpolated between bins."""
    x = samples.astype(np.float64) * np.hanning(len(samples))
    spectrum = np.abs(np.fft.rfft(x))
    k = int(np.argmax(spectrum[1:-1])) + 1
    a, b, c = np.log(spectrum[k - 1 : k + 2] + 1e-12)
    shift = 0.5 * (a - c) / (a - 2 * b + c)
    return (k + shift) * rate / len(samples)
