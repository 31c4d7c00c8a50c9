"""A curator's recorded narration, read as an untrusted file.

A timeline names its recordings; the name may be a symlink out of the tree, a FIFO (a read would
hang the kiosk), /dev/zero (never ends), a 4 GB export, or a file that only says it is a WAV.
Each is refused with "FILE: why", and a good file in any rate and channel count the decoder
accepts is converted to the exhibit's format. A recording that is silent is refused too: a
visitor who pressed "listen" and hears nothing has been failed quietly. What is accepted is
brought to narration's loudness (exhibit.narration.loudness), as synthesised speech is.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from exhibit.narration import loudness
from exhibit.narration.errors import NarrationError
from exhibit.narration.sound import Sound, read_wav_bytes
from exhibit.schema import files

#: The largest recording read (two minutes of 48 kHz 24-bit stereo is 35 MB).
MAX_BYTES = 50 * 1000 * 1000
#: The longest recording accepted: narration of one keyframe, not an audio guide.
MAX_SECONDS = 120.0
#: The shortest: a single short word takes about a quarter of a second; less is a click or an
#: export that went wrong (a 1-sample file was once accepted and "played").
MIN_SECONDS = 0.2
#: Peak below which a recording counts as silent (-60 dBFS).
SILENT_PEAK = 33


def _inside(path: Path, root: Path) -> bool:
    return path == root or root in path.parents


def load_recording(path: Path, root: Path) -> Sound:
    """The recording at ``path``, which must lie under ``root`` once symbolic links are
    resolved, as a Sound at narration's loudness (exhibit.narration.loudness.normalise).
    NarrationError "PATH: why" otherwise."""
    return loudness.normalise(_read(path, root))


def level_note(path: Path, root: Path) -> str | None:
    """A warning line naming the recording at ``path`` when, as recorded, it is far off
    narration's loudness (exhibit.narration.loudness.far_off); None when it is near, or when it
    cannot be read (that is reported by :func:`load_recording`)."""
    try:
        sound = _read(path, root)
    except NarrationError:
        return None
    return loudness.far_off(os.fspath(path), loudness.measure(sound))


def _read(path: Path, root: Path) -> Sound:
    """The recording at ``path``, checked and converted, as recorded (not yet normalised)."""
    shown = os.fspath(path)
    try:
        real_root = Path(root).resolve(strict=True)
    except OSError as exc:
        raise NarrationError(
            f"{shown}: its folder {root} cannot be read: {exc.strerror or exc}"
        ) from None
    try:
        real = Path(root, path).resolve(strict=True)
    except FileNotFoundError:
        raise NarrationError(f"{shown}: no such file") from None
    except (OSError, RuntimeError) as exc:  # a loop of links is a RuntimeError before 3.13
        raise NarrationError(
            f"{shown}: cannot be read: {getattr(exc, 'strerror', None) or exc}"
        ) from None
    if not _inside(real, real_root):
        raise NarrationError(f"{shown}: lies outside {root} (it leads to {real})")
    try:
        data = files.read_regular(real, MAX_BYTES)
    except files.NotAFile as exc:
        raise NarrationError(f"{shown}: is {exc.kind}, not a recording") from None
    except files.TooLarge as exc:
        raise NarrationError(f"{shown}: too large: {exc}") from None
    except OSError as exc:
        raise NarrationError(f"{shown}: cannot be read: {exc.strerror or exc}") from None
    sound = read_wav_bytes(data, shown, max_seconds=MAX_SECONDS)
    if len(sound.samples) == 0:
        raise NarrationError(f"{shown}: holds no audio")
    if sound.duration < MIN_SECONDS:
        raise NarrationError(
            f"{shown}: {sound.duration * 1000:.0f} ms long, under the {MIN_SECONDS:g} s a word "
            "takes: not a narration"
        )
    if sound.duration > MAX_SECONDS:  # a streaming header hides the length until decoded
        raise NarrationError(
            f"{shown}: {sound.duration:.0f} s long, over the {MAX_SECONDS:g} s limit"
        )
    if int(np.abs(sound.samples.astype(np.int32)).max()) < SILENT_PEAK:
        raise NarrationError(f"{shown}: is silent (its loudest sample is below -60 dBFS)")
    return sound
