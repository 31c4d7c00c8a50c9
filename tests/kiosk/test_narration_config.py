"""Narration in a curator's timeline, attacked (issue 35, item 6): recordings that are not audio,
huge, a FIFO, /dev/zero, a link out of the tree, a path outside it, at a rate or with channels no
device plays; descriptions blank or too long. `exhibit check-config` names each by file, keyframe
and language and exits 2, never a traceback; what it accepts, the kiosk speaks."""

from __future__ import annotations

import io
import os
import shutil
import wave
from pathlib import Path

import numpy as np
import pytest

from exhibit.cli import main
from exhibit.narration import speech

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


def wav_bytes(rate: int, channels: int, seconds: float = 1.0) -> bytes:
    t = np.arange(int(rate * seconds)) / rate
    tone = (0.3 * 32767 * np.sin(2 * np.pi * 440 * t)).astype("<i2")
    frames = np.repeat(tone[:, None], channels, axis=1)
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(frames.tobytes())
    return out.getvalue()


def site(tmp_path, keyframes: str) -> Path:
    tree = tmp_path / "configs"
    shutil.copytree(CONFIGS, tree)
    for old in (tree / "attract").glob("*.toml"):
        old.unlink()
    (tree / "attract" / "01-torus.toml").write_text(
        'scene = "clifford-torus"\n' + keyframes + "\n[[keyframe]]\nt = 60\n"
    )
    kiosk = tree / "kiosk.toml"
    kiosk.write_text(kiosk.read_text().replace('shown = ["en", "de"]', 'shown = ["en"]'))
    return tree


CAPTION = 'caption = "It never stretches; only its shadow does."'


def keyframe(t: float, narration: str) -> str:
    return f"[[keyframe]]\nt = {t}\n{CAPTION}\n{narration}\n"


@pytest.mark.skipif(not speech.available(), reason="espeak-ng is not installed (bootstrap.sh)")
def test_hostile_recordings_are_named_and_good_ones_in_any_format_are_spoken(tmp_path, capsys):
    outside = tmp_path / "outside.wav"
    outside.write_bytes(wav_bytes(22050, 1))
    cases = {
        "good-48k-stereo.wav": wav_bytes(48000, 2),  # converted: fine
        "good-8k-6ch.wav": wav_bytes(8000, 6),  # converted: fine
        "text.wav": b"this is not audio at all\n" * 10,
        "huge.wav": None,  # a sparse file far over the limit
        "fifo.wav": None,
        "link-out.wav": None,
        "nine.wav": None,
        "slow.wav": wav_bytes(1000, 1),
    }
    tree = site(tmp_path, "")
    audio = tree / "attract" / "audio"
    audio.mkdir()
    for name, data in cases.items():
        if data is not None:
            (audio / name).write_bytes(data)
    with open(audio / "huge.wav", "wb") as f:
        f.truncate(3 << 30)
    os.mkfifo(audio / "fifo.wav")
    (audio / "link-out.wav").symlink_to(outside)
    nine = bytearray(wav_bytes(22050, 1))
    nine[22:24] = (9).to_bytes(2, "little")  # nine channels in the header
    (audio / "nine.wav").write_bytes(bytes(nine))
    names = list(cases) + ["/dev/zero", "../outside.wav"]
    text = "".join(
        keyframe(
            2 * i, f'narration = {{ en = "{n if n.startswith(("/", "..")) else "audio/" + n}" }}'
        )
        for i, n in enumerate(names)
    )
    (tree / "attract" / "01-torus.toml").write_text(
        'scene = "clifford-torus"\n' + text + "\n[[keyframe]]\nt = 60\n"
    )
    code = main(["check-config", str(tree / "kiosk.toml")])
    out = capsys.readouterr()
    assert "Traceback" not in out.out + out.err
    problems = [
        line for line in out.out.splitlines() if "narration (en)" in line and "takes" not in line
    ]
    refused = {n for n in names if any(f"keyframe[{names.index(n)}]" in p for p in problems)}
    assert refused == set(names) - {"good-48k-stereo.wav", "good-8k-6ch.wav"}, problems
    assert code == 2


@pytest.mark.parametrize(
    "describe, reason",
    [('"   "', "must not be empty"), ('"' + "x" * 601 + '"', "600")],
)
def test_blank_or_overlong_descriptions_are_refused_by_key(tmp_path, capsys, describe, reason):
    tree = site(tmp_path, keyframe(0, f"describe = {describe}"))
    assert main(["check-config", str(tree / "kiosk.toml")]) == 2
    out = capsys.readouterr().out
    assert "01-torus.toml: keyframe[0].describe:" in out and reason in out
