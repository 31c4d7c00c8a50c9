"""What several kiosk test modules share (no test module imports another): a copy of the
shipped configs made small, a kiosk on a fake window and clock, a timeline and a device config
for the state machine, a config editor, and the sessions a killed child rebuilds."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from exhibit.kiosk import app
from exhibit.preparing import jobs
from exhibit.kiosk.config import load_kiosk_config
from exhibit.operations.sessions import Session
from exhibit.render.target import HeadlessTarget
from tests.golden.kiosk_frames import FakeClock, keyboard_devices

ROOT = Path(__file__).resolve().parents[2]


def make_config(tmp: Path, script: str) -> Path:
    configs = tmp / "configs"
    shutil.copytree(ROOT / "configs", configs)
    (configs / "controller.script").write_text(script)
    devices = configs / "devices" / "default.toml"
    text = devices.read_text()
    text = re.sub(
        r'url = "serial://[^"]*"',
        f'url = "sim://controller?script={configs / "controller.script"}"',
        text,
    )
    text = re.sub(r'url = "hidraw://[^"]*"', 'url = "keyboard://"', text, count=0)
    devices.write_text(text)
    for timeline in (configs / "attract").glob("*.toml"):
        if not timeline.name.startswith("01-"):
            timeline.unlink()
    kiosk = configs / "kiosk.toml"
    text = kiosk.read_text()
    text = re.sub(r"scenes = \[[^\]]*\]", 'scenes = ["hopf", "clifford-torus"]', text)
    text = text.replace("resolution = { hopf = 48, collision = 40 }", "resolution = { hopf = 16 }")
    text = text.replace("size = [1280, 720]", "size = [320, 240]")
    text = text.replace("samples = 4 ", "samples = 0 ")
    text = text.replace("idle_timeout_s = 90 ", "idle_timeout_s = 5 ")
    kiosk.write_text(text)
    return kiosk


def windowed_env(tmp: Path, display: str) -> dict[str, str]:
    """The environment of a kiosk in a window on ``display``, with its own cache and state
    folders in ``tmp`` and no systemd to notify."""
    env = dict(
        os.environ,
        DISPLAY=display,
        EXHIBIT_CACHE_DIR=str(tmp / "cache"),
        EXHIBIT_STATE_DIR=str(tmp / "state"),
    )
    env.pop("NOTIFY_SOCKET", None)
    return env


def run_windowed(kiosk: Path, tmp: Path, *args: str) -> tuple[subprocess.CompletedProcess, dict]:
    """`exhibit run --config KIOSK --windowed ARGS...` in a window under Xvfb, with its own
    cache and state folders in ``tmp``: the finished process and its environment (the test is
    skipped when Xvfb cannot give GLFW a window)."""
    from tests.xvfb import unavailable, xvfb

    with xvfb("640x480x24") as display:
        env = windowed_env(tmp, display)
        result = subprocess.run(
            [sys.executable, "-m", "exhibit", "run", "--config", str(kiosk), "--windowed", *args],
            env=env,
            capture_output=True,
            text=True,
            timeout=240,
            cwd=ROOT,
        )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable(f"no GLFW window on Xvfb: {result.stderr.strip().splitlines()[-1]}")
    assert result.returncode == 0, result.stderr
    return result, env


class FakeWindow:
    """What Kiosk needs of a window, drawing nothing; ``fail`` counts down frames that raise."""

    def __init__(self):
        self.close_allowed, self.handler = True, None
        self.ctx = SimpleNamespace(error="GL_NO_ERROR", info={})
        self.renderer = SimpleNamespace(upload=lambda mesh: mesh)
        self.size = (640, 360)
        self.refresh_hz = None
        self.frame_ms = None
        self.fail = 0
        self.drawn, self.notices = [], 0
        self.fades, self.captured = [], []
        self.measure_asked, self.pass_times = 0, None

    def draw(self, request):
        if self.fail > 0:
            self.fail -= 1
            raise ZeroDivisionError("a bug in the renderer")
        self.drawn.append(request.gpu)
        self.fades.append(request.fade)

    def capture(self, request):
        self.captured.append(request.gpu)

    def warm_hud(self, huds, text):
        pass

    def release_snapshot(self):
        pass

    def measure_passes(self):
        self.measure_asked += 1

    def notice(self, lines, drift=(0.0, 0.0)):
        self.notices += 1

    def swap(self):
        pass

    def set_input(self, handler):
        self.handler = handler

    def hide_cursor(self):
        pass


class Notifier:
    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *a: self.calls.append(name)


def kiosk(tmp_path, monkeypatch, broken=(), clock=None, window=None, reduced_motion=False):
    """A Kiosk on a fake window (``window``, default FakeWindow()) and a clock that moves 0.1 s
    per reading (about 0.2 s a frame; or ``clock``); building a mesh for a scene in ``broken``
    raises (``broken`` True: every scene). ``reduced_motion``: [accessibility]'s."""
    path = make_config(tmp_path, "")
    devices = path.parent / "devices" / "default.toml"  # keyboards only: no simulator thread
    devices.write_text(re.sub(r'url = "sim://[^"]*"', 'url = "keyboard://"', devices.read_text()))
    if reduced_motion:
        edit(path, "reduced_motion = false", "reduced_motion = true")
    config = load_kiosk_config(path)

    def build(scene, params, resolution):
        if broken is True or scene.name in broken:
            raise RuntimeError(f"cannot build {scene.name}")
        return f"mesh {scene.name}", None

    monkeypatch.setattr(jobs, "build_cached", build)
    if clock is None:
        ticks = iter(np.arange(1e6) * 0.1)

        def clock():
            return float(next(ticks))

    notifier = Notifier()
    k = app.Kiosk(
        config,
        window if window is not None else FakeWindow(),
        clock=clock,
        notifier=notifier,
        health_path=tmp_path / "health.json",
    )
    # the start-up warm-up drew every quality level once through a crossfade (not frames;
    # nothing when no scene could be prepared)
    warm = len(k.parts.governor.levels) if k.state is not None else 0
    assert len(k.window.drawn) == len(k.window.captured) == warm
    k.window.drawn, k.window.captured, k.window.fades = [], [], []
    return k, notifier


TIMELINE = """
scene = "hopf"
[[keyframe]]
t = 0
angles = [0, 0, 0, 0, 0, 0]
sensor_distance = "inf"
caption = "far"
[[keyframe]]
t = 10
angles = [90, 0, 0, 0, 0, 0]
sensor_distance = 2
caption = "near"
ease = "linear"
[[keyframe]]
t = 20
angles = [90, -30, 0, 0, 0, 0]
"""


DEVICES = """
[devices.knobs]
url = "keyboard://"
[[mapping.bind]]
device = "knobs"
input = "delta 1"
param = "theta1"
step = 5
[[mapping.bind]]
device = "knobs"
input = "button 1"
action = "home"
"""


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def numbered(i: int, base: float | None = None) -> Session:
    """Session number i, rebuilt identically by the killed child and the test; ``base``
    (default: a day ago) is recent, so rotation by age keeps it."""
    base = float(int(time.time()) - 86400) if base is None else base
    return Session(
        base + i,
        base + i + 60,
        60.0,
        30.0,
        3600,
        "en",
        ["hopf", f"scene-{i % 7}"],
        [f"device-{i % 3}.knob"],
    )


SIZE = (320, 180)
IDLE_S = 5.0


class HeadlessKiosk:
    """A kiosk with two scenes and one short attract timeline, the shipped keyboard mapping as
    its only device, quality pinned, at 10 frames a second of test time."""

    def __init__(self, headless, tmp: Path, extra: str = ""):
        keyboard_devices(tmp / "devices.toml")
        (tmp / "attract").mkdir()
        (tmp / "attract" / "torus.toml").write_text(
            'name = "Torus"\nscene = "clifford-torus"\n'
            '[[keyframe]]\nt = 0\ncaption = "Closer still."\n'
            "[[keyframe]]\nt = 30\nangles = [90, -40, 0, 0, 0, 0]\n"
        )
        site = tmp / "kiosk.toml"
        site.write_text(f"""
[display]
size = [{SIZE[0]}, {SIZE[1]}]
[content]
scenes = ["clifford-torus", "hopf"]
start_scene = "clifford-torus"
resolution = {{ clifford-torus = 12, hopf = 12 }}
[devices]
config = "devices.toml"
[attract]
timelines = "attract"
idle_timeout_s = {IDLE_S}
blend_s = 1.0
[quality]
level = "fxaa"
{extra}""")
        self.clock = FakeClock(0.0)
        self.target = HeadlessTarget(headless, SIZE)
        self.kiosk = app.Kiosk(load_kiosk_config(site), self.target, clock=self.clock)

    def run(self, seconds: float, step: float = 0.1) -> None:
        for _ in range(round(seconds / step)):
            self.clock.t = round(self.clock.t + step, 6)
            self.kiosk.step()

    @property
    def frame(self):
        return self.kiosk.state.frame
