"""`exhibit run` in a real window under Xvfb, with the simulated controller on a pty: it starts
and draws, controller input hands control to the visitor and turns the view, and the idle timeout
returns to attract mode. One run of about 12 s, observed through its log and its screenshot."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from tests.kiosk.support import ROOT, make_config, run_windowed
from tests.xvfb import unavailable, xvfb


@pytest.fixture(scope="module")
def kiosk_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("kiosk")
    # 2 s of attract, then a stick deflected for 1.5 s, then nobody: attract returns after 5 s.
    kiosk = make_config(tmp, "wait 2\naxes 0.9 0 0 0 0 0\nwait 1.5\naxes 0 0 0 0 0 0\n")
    shot = tmp / "last.png"
    result, _ = run_windowed(kiosk, tmp, "--duration", "12", "--screenshot", str(shot))
    return result, shot, tmp


def mode_changes(log: str) -> list[tuple[str, list[float]]]:
    changes = []
    for mode, angles in re.findall(r"mode (\w+): scene \S+, angles \(([^)]*)\)", log):
        changes.append((mode, [float(a) for a in angles.split(",")]))
    return changes


@pytest.mark.serial
@pytest.mark.slow  # the kiosk run for seconds in a real window (CI runs it)
def test_the_kiosk_draws_a_picture(kiosk_run):
    _, shot, _ = kiosk_run
    picture = np.asarray(Image.open(shot).convert("RGB"), dtype=float)
    assert picture.shape == (240, 320, 3)
    assert picture.std() > 10  # not a blank screen


@pytest.mark.serial
@pytest.mark.slow  # the kiosk run for seconds in a real window (CI runs it)
def test_controller_input_takes_over_and_idle_returns_to_attract(kiosk_run):
    result, _, _ = kiosk_run
    changes = mode_changes(result.stderr)
    assert [mode for mode, _ in changes][:2] == ["visitor", "attract"], result.stderr
    (_, taken_over), (_, left) = changes[:2]
    # about 1.5 s at 0.9 deflection, 90 degrees/s, square curve: theta1 turned by ~100 degrees
    turned = (left[0] - taken_over[0] + 180) % 360 - 180
    assert abs(turned) > 45, changes
    assert left[1:] == taken_over[1:]  # only the deflected stick moved


@pytest.mark.serial
@pytest.mark.slow  # the kiosk run for seconds in a real window (CI runs it)
def test_health_file_is_written(kiosk_run):
    _, _, tmp = kiosk_run
    import json

    health = json.loads((tmp / "state" / "health.json").read_text())
    assert health["mode"] in ("attract", "visitor") and health["fps"] > 0
    assert health["gl_errors"] == 0


@pytest.mark.serial
@pytest.mark.slow  # the kiosk run for seconds in a real window (CI runs it)
def test_watchdog_pings_follow_the_frame_loop(tmp_path):
    """Under a test NOTIFY_SOCKET: READY after the first frame, then WATCHDOG every half period;
    a stalled loop (the process stopped) sends none, and they resume when it runs again."""
    import signal
    import socket
    import time

    kiosk = make_config(tmp_path, "wait 60\n")
    address = str(tmp_path / "notify.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    server.bind(address)
    server.settimeout(0.1)

    def messages(seconds, until=None):
        got, end = [], time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                got.append(server.recv(4096).decode())
            except TimeoutError:
                continue
            if until is not None and until in got[-1]:
                break
        return got

    with xvfb() as display:
        env = dict(
            os.environ,
            DISPLAY=display,
            EXHIBIT_CACHE_DIR=str(tmp_path / "cache"),
            EXHIBIT_STATE_DIR=str(tmp_path / "state"),
            NOTIFY_SOCKET=address,
            WATCHDOG_USEC="400000",
        )
        env.pop("WATCHDOG_PID", None)
        child = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "exhibit",
                "run",
                "--config",
                str(kiosk),
                "--windowed",
                "--duration",
                "60",
            ],
            env=env,
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            started = messages(60, until="READY=1")
            if child.poll() is not None and "cannot start GLFW" in child.stderr.read():
                unavailable("no GLFW window on Xvfb")
            assert any("READY=1" in m for m in started), started
            assert sum("WATCHDOG=1" in m for m in messages(1.5)) >= 4
            child.send_signal(signal.SIGSTOP)  # a hung loop
            time.sleep(0.05)
            messages(0.2)  # drain what was sent before the stop
            assert not any("WATCHDOG=1" in m for m in messages(1.5))
            child.send_signal(signal.SIGCONT)
            assert any("WATCHDOG=1" in m for m in messages(1.5))
        finally:
            child.send_signal(signal.SIGCONT)
            child.terminate()
            child.wait(timeout=30)
            child.stderr.close()
            server.close()


def test_fullscreen_fills_the_monitor_and_a_missing_monitor_falls_back():
    code = (
        "from exhibit.render.window import Window\n"
        "w = Window(size=(320, 240), fullscreen=True, samples=0, monitor=3)\n"
        "print(*w.size); w.close()\n"
    )
    with xvfb("800x600x24") as display:
        result = subprocess.run(
            [sys.executable, "-c", code],
            env=dict(os.environ, DISPLAY=display),
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable("no GLFW window on Xvfb")
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["800", "600"]
