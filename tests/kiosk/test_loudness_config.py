"""`exhibit check-config` notes a curator's recording far off narration's loudness target (issue 42,
item 4): a warning line naming the file, not a problem (the recording is still brought to the
target and spoken; the exit status stays 0)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from exhibit.cli import main
from exhibit.narration import speech
from tests.narration.support import pcm_wav, sine

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


def site(tmp_path, recordings: dict[str, np.ndarray]) -> Path:
    """A site with one timeline in English whose keyframes speak ``recordings`` (name: samples
    at 48 kHz), under attract/audio/."""
    tree = tmp_path / "configs"
    shutil.copytree(CONFIGS, tree)
    for old in (tree / "attract").glob("*.toml"):
        old.unlink()
    audio = tree / "attract" / "audio"
    audio.mkdir()
    text = 'scene = "clifford-torus"\n'
    for i, (name, samples) in enumerate(recordings.items()):
        (audio / name).write_bytes(pcm_wav(samples, 48000, 24))
        text += (
            f'[[keyframe]]\nt = {10 * i}\ncaption = "It never stretches; only its shadow does."\n'
            f'narration = {{ en = "audio/{name}" }}\n'
        )
    (tree / "attract" / "01-torus.toml").write_text(text + "\n[[keyframe]]\nt = 60\n")
    kiosk = tree / "kiosk.toml"
    kiosk.write_text(kiosk.read_text().replace('shown = ["en", "de"]', 'shown = ["en"]'))
    return tree


@pytest.mark.skipif(not speech.available(), reason="espeak-ng is not installed (bootstrap.sh)")
def test_a_recording_far_off_the_target_is_noted_by_name(tmp_path, capsys):
    tree = site(
        tmp_path,
        {
            "loud.wav": sine(440, 2.0, 48000, amplitude=0.9),  # about -5 LUFS: 18 LU over
            "near.wav": sine(440, 2.0, 48000, amplitude=0.07),  # about -27 LUFS: 4 LU under
            "faint.wav": sine(440, 2.0, 48000, amplitude=0.003),  # about -54 LUFS: 31 LU under
        },
    )
    code = main(["check-config", str(tree / "kiosk.toml")])
    out = capsys.readouterr().out
    warnings = [line for line in out.splitlines() if line.startswith("warning: ")]
    assert code == 0, out
    assert len(warnings) == 2, out
    loud = next(line for line in warnings if "loud.wav" in line)
    faint = next(line for line in warnings if "faint.wav" in line)
    assert loud.startswith("warning: ") and "/audio/loud.wav: recorded at " in loud
    assert "LU louder than narration's -23 LUFS" in loud
    assert "/audio/faint.wav: recorded at " in faint
    assert "LU quieter" in faint
    assert "near.wav" not in out
