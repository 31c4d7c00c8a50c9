"""`exhibit run` with narration on ([narration] attract = true) in a real window under Xvfb
(issue 35): with a sound device (miniaudio's null device: it takes samples in real time, as a
speaker does) it speaks, and with the site's device absent it runs on all the same; both say so
in the health file and `exhibit status`."""

import json
import subprocess
import sys

import pytest

from tests.kiosk.support import ROOT, make_config, run_windowed


def run_kiosk(tmp, narration: str):
    kiosk = make_config(tmp, "wait 30\n")
    text = kiosk.read_text()
    kiosk.write_text(text.split("[narration]")[0] + "[narration]\n" + narration)
    _, env = run_windowed(kiosk, tmp, "--duration", "15")  # room for a busy machine
    status = subprocess.run(
        [sys.executable, "-m", "exhibit", "status", "--max-age", "3600"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    health = json.loads((tmp / "state" / "health.json").read_text())
    return health, status.stdout


@pytest.mark.serial
@pytest.mark.slow  # two kiosk runs of seconds in a real window (CI runs them)
def test_narration_plays_on_a_device_and_the_kiosk_runs_on_without_one(tmp_path):
    health, status = run_kiosk(tmp_path / "null", 'attract = true\nbackend = "null"\n')
    narration = health["narration"]
    assert narration["player"]["state"] == "ok", narration
    assert narration["speaking"] and narration["sounds"] >= 1 and not narration["failed"]
    assert "narration" in status and "sound: ok" in status

    health, status = run_kiosk(tmp_path / "absent", 'attract = true\ndevice = "no such speaker"\n')
    narration = health["narration"]
    assert narration["player"]["state"] in ("absent", "error"), narration
    assert health["frames"] >= 2  # drawing all along (few on a busy machine)
    assert "sound: absent" in status or "sound: error" in status
