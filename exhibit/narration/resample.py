"""Changing a mono signal's sample rate with numpy alone.

Linear interpolation keeps a tone's pitch exactly (the time axis is mapped, not stretched), but
going down in rate it folds everything above the new Nyquist back into the audible band. So a
rate going down is first low-passed (a Kaiser-windowed sinc, applied by FFT in blocks, so a
two-minute 192 kHz recording costs no more memory than itself) and then interpolated. Speech
lives below 8 kHz and the exhibit plays at 22.05 kHz, so the filter's gentle transition band
(0.9 of the new Nyquist) costs nothing a visitor hears.
"""

from __future__ import annotations

import numpy as np

#: Filter taps (odd, so the filter is centred on a sample) and the Kaiser window's beta (~80 dB).
TAPS = 255
BETA = 8.0
_BLOCK = 1 << 16


def lowpass(cutoff: float) -> np.ndarray:
    """A linear-phase low-pass with ``cutoff`` as a fraction of the sample rate (< 0.5)."""
    n = np.arange(TAPS) - (TAPS - 1) / 2
    taps = 2 * cutoff * np.sinc(2 * cutoff * n) * np.kaiser(TAPS, BETA)
    return (taps / taps.sum()).astype(np.float32)


def _filter(x: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """``x`` convolved with ``taps``, same length, delay removed (overlap-add by FFT)."""
    m = len(taps)
    size = _BLOCK + m - 1
    spectrum = np.fft.rfft(taps, size)
    out = np.zeros(len(x) + m - 1, dtype=np.float32)
    for start in range(0, len(x), _BLOCK):
        block = x[start : start + _BLOCK]
        piece = np.fft.irfft(np.fft.rfft(block, size) * spectrum, size)[: len(block) + m - 1]
        out[start : start + len(piece)] += piece.astype(np.float32)
    delay = (m - 1) // 2
    return out[delay : delay + len(x)]


def resample(x: np.ndarray, source: int, target: int) -> np.ndarray:
    """``x`` (float, mono) sampled at ``source`` Hz, resampled to ``target`` Hz (float32)."""
    x = np.asarray(x, dtype=np.float32)
    if source == target or len(x) == 0:
        return x.copy()
    if target < source:
        x = _filter(x, lowpass(0.45 * target / source))
    count = int(round(len(x) * target / source))
    positions = np.arange(count, dtype=np.float64) * (source / target)
    left = np.minimum(positions.astype(np.int64), len(x) - 1)
    right = np.minimum(left + 1, len(x) - 1)
    frac = (positions - left).astype(np.float32)
    return x[left] * (1 - frac) + x[right] * frac
