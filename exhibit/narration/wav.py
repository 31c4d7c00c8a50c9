"""Reading a RIFF/WAVE file from bytes, without trusting a field of it.

Python's ``wave`` reads neither float nor WAVE_FORMAT_EXTENSIBLE files (what most editors export
for 24-bit or more than two channels), so this reads the chunks itself: every size is checked
against the bytes there are, the format against what the exhibit can convert, and the length the
header declares against a limit *before* anything is decoded (a header claiming three hours
costs no memory). A data size of 0x7FFFxxxx or 0xFFFFFFFF is a streaming writer's "until the
end" (espeak-ng --stdout writes one), read as the bytes that follow.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

#: Rates and channel counts accepted (a telephone recording to a studio master; 7.1 at most).
MIN_RATE, MAX_RATE = 8000, 192000
MAX_CHANNELS = 8
#: Data sizes a streaming writer puts in the header when it cannot seek back.
_STREAMING = 0x7FFF0000
_PCM, _FLOAT, _EXTENSIBLE = 1, 3, 0xFFFE


class WavProblem(ValueError):
    """What is wrong with the bytes, in words (the caller adds the file's name)."""


@dataclass(frozen=True)
class Header:
    rate: int
    channels: int
    bits: int
    floating: bool
    frames: int  # in the data that is there (or declared, for the duration check)


def _chunks(data: bytes) -> tuple[bytes | None, int, int]:
    """The fmt chunk's body, and the offset and length of the data chunk's."""
    if len(data) < 12:
        raise WavProblem(f"only {len(data)} bytes, too short for a WAV header")
    if data[:4] != b"RIFF" or data[8:12] != b"WAVE":
        raise WavProblem("not a WAV file (no RIFF/WAVE header)")
    fmt, pos = None, 12
    while pos + 8 <= len(data):
        kind, size = data[pos : pos + 4], struct.unpack_from("<I", data, pos + 4)[0]
        body = pos + 8
        if kind == b"data":
            if fmt is None:
                raise WavProblem("the data chunk comes before the fmt chunk")
            left = len(data) - body
            if size >= _STREAMING:
                size = left
            return fmt, body, size
        if size > len(data) - body:
            raise WavProblem(
                f"the {kind!r} chunk says {size} bytes, but only {len(data) - body} follow"
            )
        if kind == b"fmt ":
            fmt = data[body : body + size]
        pos = body + size + (size & 1)  # chunks are padded to an even length
    raise WavProblem(
        "no data chunk (truncated?)" if fmt is not None else "no fmt chunk (truncated?)"
    )


def read_header(data: bytes) -> tuple[Header, int, int]:
    """The format and the data's offset and declared length; WavProblem for anything outside
    what :func:`decode` converts."""
    fmt, offset, size = _chunks(data)
    if fmt is None or len(fmt) < 16:
        raise WavProblem("the fmt chunk is shorter than 16 bytes")
    tag, channels, rate, _, align, bits = struct.unpack_from("<HHIIHH", fmt)
    if tag == _EXTENSIBLE:
        if len(fmt) < 40:
            raise WavProblem("an extensible fmt chunk shorter than 40 bytes")
        tag = struct.unpack_from("<H", fmt, 24)[0]  # the sub-format GUID starts with the tag
    if tag not in (_PCM, _FLOAT):
        raise WavProblem(f"format tag {tag:#06x}: only PCM and IEEE float WAV files are accepted")
    floating = tag == _FLOAT
    if not 1 <= channels <= MAX_CHANNELS:
        raise WavProblem(f"{channels} channels: 1 to {MAX_CHANNELS} are accepted")
    if not MIN_RATE <= rate <= MAX_RATE:
        raise WavProblem(f"sample rate {rate} Hz: {MIN_RATE} to {MAX_RATE} Hz are accepted")
    widths = (32, 64) if floating else (8, 16, 24, 32)
    if bits not in widths:
        kind = "float" if floating else "integer"
        raise WavProblem(f"{bits}-bit {kind} samples: {', '.join(map(str, widths))} are accepted")
    if align != channels * bits // 8:
        raise WavProblem(f"block align {align} does not match {channels} x {bits} bits")
    return Header(rate, channels, bits, floating, size // align), offset, size


def decode(data: bytes, max_seconds: float | None = None) -> tuple[np.ndarray, int]:
    """The mono mixdown (float32 in [-1, 1]) and its rate. ``max_seconds``: a longer declared
    length is refused from the header, before decoding."""
    header, offset, size = read_header(data)
    seconds = header.frames / header.rate
    if max_seconds is not None and seconds > max_seconds:
        raise WavProblem(
            f"its header says {_clock(seconds)} of audio, over the {max_seconds:g} s limit"
        )
    if offset + size > len(data):
        raise WavProblem(
            f"the data chunk says {size} bytes, but only {len(data) - offset} follow (truncated)"
        )
    frames = header.frames
    align = header.channels * header.bits // 8
    raw = np.frombuffer(data, dtype=np.uint8, count=frames * align, offset=offset)
    raw = raw.reshape(frames, header.channels, header.bits // 8)
    mono = np.zeros(frames, dtype=np.float32)
    for c in range(header.channels):  # one channel at a time: at most one more copy in memory
        mono += _channel(raw[:, c, :], header)
    mono /= header.channels
    if not np.all(np.isfinite(mono)):
        raise WavProblem("it holds NaN or infinite samples")
    np.clip(mono, -1.0, 1.0, out=mono)
    return mono, header.rate


def _channel(raw: np.ndarray, header: Header) -> np.ndarray:
    """One channel's bytes (frames x width) as float32 in [-1, 1]."""
    block = np.ascontiguousarray(raw)
    if header.floating:
        kind = "<f4" if header.bits == 32 else "<f8"
        return block.view(kind)[:, 0].astype(np.float32)
    if header.bits == 8:  # unsigned, 128 is zero
        return (block[:, 0].astype(np.float32) - 128.0) / 128.0
    if header.bits == 24:  # little-endian, sign-extended from the top byte
        value = block[:, 0].astype(np.int32) | (block[:, 1].astype(np.int32) << 8)
        value |= block[:, 2].astype(np.int8).astype(np.int32) << 16
        return value.astype(np.float32) / float(1 << 23)
    kind = "<i2" if header.bits == 16 else "<i4"
    return block.view(kind)[:, 0].astype(np.float32) / float(1 << (header.bits - 1))


def _clock(seconds: float) -> str:
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
