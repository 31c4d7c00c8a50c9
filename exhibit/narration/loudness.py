"""How loud narration is: measured as ITU-R BS.1770 says, and brought to one target.

Every sound narration plays (espeak-ng's speech and a curator's recordings) is measured for its
integrated loudness (BS.1770-4, K-weighted and gated, by pyloudnorm) and its true peak (the
largest sample of the signal oversampled 4 times, as BS.1770 Annex 2 does, by
scipy.signal.resample_poly), then scaled by one gain so that it sits at :data:`TARGET_LUFS`,
never above :data:`CEILING_DBTP`. So a recording and a synthesised caption sound equally loud,
and the review's AAC encode or a resampler has headroom to overshoot into without clipping.

Pure: samples in, numbers or samples out, no files. scipy and pyloudnorm are imported when a
sound is first measured, not when the kiosk starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from exhibit.narration.sound import RATE, Sound

#: The loudness every narration sound is brought to, in LUFS. -23 LUFS is EBU R128's programme
#: level. Louder targets (-16 LUFS, podcasts) suit a phone, but speech peaks 12-22 dB above its
#: loudness (espeak-ng's about 18 dB), so at -16 LUFS its peaks would need a limiter to stay
#: under the ceiling; at -23 LUFS one plain gain keeps every speech peak under it. How loud the
#: hall hears it is set once, by the kiosk's amplifier, so a lower digital level costs nothing
#: but a few of 16 bits' 96 dB.
TARGET_LUFS = -23.0
#: The highest true peak a narration sound may have after its gain, in dBTP: 1 dB of headroom
#: for the review's AAC encode and for any resampler after the exhibit (both overshoot).
CEILING_DBTP = -1.0
#: Kept below the ceiling when the gain is chosen, so rounding to int16 cannot cross it.
MARGIN_DB = 0.05
#: A recording whose own loudness is further than this from the target is noted by
#: `exhibit check-config` (it is still brought to the target; the note asks for a better export).
FAR_OFF_LU = 6.0
#: True peak: the signal oversampled this many times (BS.1770-4, Annex 2).
OVERSAMPLE = 4
#: BS.1770's gating block: a shorter sound is measured as itself repeated to this length.
BLOCK_S = 0.4


@dataclass(frozen=True)
class Level:
    """A sound's integrated loudness (LUFS) and true peak (dBTP); -inf for silence."""

    loudness: float
    true_peak: float

    def __str__(self) -> str:
        return f"{self.loudness:.1f} LUFS, true peak {self.true_peak:.1f} dBTP"


def _db(value: float) -> float:
    return 20.0 * math.log10(value) if value > 0 else -math.inf


def true_peak(x: np.ndarray) -> float:
    """The true peak of ``x`` (float, full scale 1.0) in dBTP: the largest magnitude of ``x``
    oversampled :data:`OVERSAMPLE` times (never below its largest sample)."""
    from scipy.signal import resample_poly

    x = np.asarray(x, dtype=np.float64)
    if len(x) == 0:
        return -math.inf
    over = resample_poly(x, OVERSAMPLE, 1)
    return _db(max(float(np.abs(over).max()), float(np.abs(x).max())))


def integrated_loudness(x: np.ndarray, rate: int = RATE) -> float:
    """The integrated loudness of ``x`` (float, mono, full scale 1.0) in LUFS (BS.1770-4);
    -inf for silence. A sound shorter than one gating block is measured repeated to one."""
    import pyloudnorm

    x = np.asarray(x, dtype=np.float64)
    if len(x) == 0 or not np.any(x):
        return -math.inf
    block = int(math.ceil(BLOCK_S * rate)) + 1
    if len(x) <= block:
        x = np.tile(x, block // len(x) + 1)
    value = float(pyloudnorm.Meter(rate).integrated_loudness(x))
    return value if math.isfinite(value) else -math.inf


def _float(sound: Sound) -> np.ndarray:
    return sound.samples.astype(np.float64) / 32768.0


def measure(sound: Sound) -> Level:
    """``sound``'s loudness and true peak."""
    x = _float(sound)
    return Level(integrated_loudness(x), true_peak(x))


def gain_db(level: Level) -> float:
    """The gain (dB) that brings a sound at ``level`` to :data:`TARGET_LUFS`, or less where its
    true peak would pass :data:`CEILING_DBTP`; 0 for silence (nothing to measure)."""
    if not (math.isfinite(level.loudness) and math.isfinite(level.true_peak)):
        return 0.0
    return min(TARGET_LUFS - level.loudness, CEILING_DBTP - MARGIN_DB - level.true_peak)


def normalise(sound: Sound, level: Level | None = None) -> Sound:
    """``sound`` at the target loudness under the true-peak ceiling (:func:`gain_db`);
    ``level``: its measure when already known."""
    gain = gain_db(measure(sound) if level is None else level)
    if gain == 0.0:
        return sound
    scaled = np.rint(_float(sound) * (10.0 ** (gain / 20.0)) * 32768.0)
    return Sound(np.clip(scaled, -32768, 32767).astype(np.int16))


def far_off(name: str, level: Level) -> str | None:
    """A warning line for a recording (``name``) whose loudness as recorded (``level``) is
    more than :data:`FAR_OFF_LU` from the target, or whose peaks keep it more than 1 LU under
    the target; None when it is fine."""
    if not math.isfinite(level.loudness):
        return None
    off = level.loudness - TARGET_LUFS
    after = level.loudness + gain_db(level)
    if abs(off) > FAR_OFF_LU:
        return (
            f"warning: {name}: recorded at {level.loudness:.1f} LUFS, {abs(off):.1f} LU "
            f"{'louder' if off > 0 else 'quieter'} than narration's {TARGET_LUFS:g} LUFS: it is "
            f"brought to it{_short(after)}, but an export nearer the target sounds better"
        )
    if after < TARGET_LUFS - 1.0:
        return f"warning: {name}: recorded at {level.loudness:.1f} LUFS{_short(after)}"
    return None


def _short(after: float) -> str:
    if after >= TARGET_LUFS - 1.0:
        return ""
    return (
        f" (its peaks leave room for {after:.1f} LUFS only, under a {CEILING_DBTP:g} dBTP "
        "ceiling: it will sound quieter than the rest)"
    )
