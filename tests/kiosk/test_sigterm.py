"""systemd stops the kiosk, and restarts it for an update, with SIGTERM: the kiosk ends as the
maintenance keys end it (exit 0, STOPPING=1), and the visitor at the controller when it came
is in the session log. Before: Python's default, death at once, the session lost."""

from __future__ import annotations

import json
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from tests.kiosk.support import ROOT, make_config, windowed_env
from tests.xvfb import unavailable, xvfb

#: A visitor who takes over after 1 s and keeps turning (never idle) until the kiosk stops.
VISITOR = "wait 1\naxes 0.6 0 0 0 0 0\nwait 100000\n"


def health(path):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_stop_signal_ends_the_kiosk_cleanly_and_keeps_the_visitors_session(tmp_path, sig):
    kiosk = make_config(tmp_path, VISITOR)
    state = tmp_path / "state"
    with xvfb("640x480x24") as display:
        env = windowed_env(tmp_path, display)
        process = subprocess.Popen(
            [sys.executable, "-m", "exhibit", "run", "--config", str(kiosk), "--windowed"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=ROOT,
        )
        try:
            deadline = time.monotonic() + 180
            while health(state / "health.json").get("mode") != "visitor":
                if process.poll() is not None or time.monotonic() > deadline:
                    break
                time.sleep(0.2)
            if process.poll() is None:
                process.send_signal(sig)
            _, err = process.communicate(timeout=60)
        finally:
            if process.poll() is None:
                process.kill()
                process.communicate()
    if "cannot start GLFW" in err:
        unavailable("no GLFW window on Xvfb")
    assert process.returncode == 0, err[-3000:]
    assert f"stopped on {sig.name}" in err, err[-3000:]
    with sqlite3.connect(state / "sessions.db") as con:
        rows = con.execute("select inputs from sessions").fetchall()
    assert len(rows) == 1, err[-3000:]
