"""Soak (slow): thousands of frames on an accelerated clock — an hour of kiosk time — in a real
window, with the simulated controller unplugging and replugging all along. Memory stays flat
(RSS growth <= 2 MB over the second half hour, after the warm-up's bounded caches have filled:
tests/kiosk/soak_run.py), file descriptors do not grow, and GL reports no error."""

import json
import os
import subprocess
import sys

import pytest

from tests.kiosk.support import ROOT, make_config
from tests.xvfb import unavailable, xvfb


@pytest.mark.slow
@pytest.mark.serial  # alone: it times nothing, but memory is measured best without neighbours
def test_an_hour_of_frames_with_device_churn(tmp_path):
    script = "axes 0.6 0 0 0 0 0\nwait 0.5\naxes 0 0 0 0 0 0\nwait 0.5\nunplug 0.5\nrepeat\n"
    kiosk = make_config(tmp_path, script)
    with xvfb() as display:
        env = dict(
            os.environ,
            DISPLAY=display,
            EXHIBIT_CACHE_DIR=str(tmp_path / "cache"),
            EXHIBIT_STATE_DIR=str(tmp_path / "state"),
        )
        result = subprocess.run(
            [sys.executable, "-m", "tests.kiosk.soak_run", str(kiosk), "5000", "0.75"],
            env=env,
            capture_output=True,
            text=True,
            timeout=1200,
            cwd=ROOT,
        )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable("no GLFW window on Xvfb")
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["simulated_s"] >= 3600
    assert report["gl_errors"] == 0
    assert report["end"]["fds"] <= report["warm"]["fds"]
    assert report["end"]["rss_kb"] - report["warm"]["rss_kb"] <= 2048, report
