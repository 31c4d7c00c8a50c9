"""Issue 41, item 6: while a scene a visitor chose is prepared, the picture held on screen stays
honest. It still answers the controls (the visitor turns the scene they were in), its caption
gives way to the preparing notice, and the health file and `exhibit status` name the scene
shown and the one being prepared. Fake window, fake clock, fake meshes: nothing waits."""

from __future__ import annotations

import json
import math
import re
import shutil

import numpy as np
import pytest

from exhibit import scenes
from exhibit.cli import main
from exhibit.kiosk import app, frame_loop
from exhibit.kiosk.config import load_kiosk_config
from exhibit.kiosk.language import PREPARING
from exhibit.preparing import jobs as jobs_module
from exhibit.preparing.preparing import InlinePreparer
from tests.kiosk.support import ROOT, FakeWindow, Notifier, make_config


class Window(FakeWindow):
    """FakeWindow that keeps every request drawn."""

    def __init__(self):
        super().__init__()
        self.requests = []

    def draw(self, request):
        super().draw(request)
        self.requests.append(request)


@pytest.fixture
def kiosk(tmp_path, monkeypatch):
    return _kiosk(tmp_path, monkeypatch)


def _kiosk(tmp_path, monkeypatch, tick=0.1):
    """A kiosk on keyboards, hopf shown first; the Clifford torus, the next scene, is
    prepared by an InlinePreparer that runs a job only when the test collects. Its clock
    moves ``tick`` s per reading."""
    path = make_config(tmp_path, "")
    shutil.copy(ROOT / "configs" / "attract" / "07-gallery.toml", path.parent / "attract")
    devices = path.parent / "devices" / "default.toml"
    devices.write_text(re.sub(r'url = "sim://[^"]*"', 'url = "keyboard://"', devices.read_text()))
    monkeypatch.setattr(
        jobs_module, "build_cached", lambda scene, params, res: (f"mesh {scene.name}", None)
    )
    monkeypatch.setattr(jobs_module, "frame", lambda timeline, *rest: timeline)
    ticks = iter(np.arange(1e6) * tick)
    return app.Kiosk(
        load_kiosk_config(path),
        Window(),
        clock=lambda: float(next(ticks)),
        notifier=Notifier(),
        health_path=tmp_path / "health.json",
        preparer=InlinePreparer,
    )


def _wait_for_the_next_scene(k):
    """The first picture (hopf), then "n": the Clifford torus, not prepared, is held for."""
    k.step()
    params = k.state.frame.params
    k.devices.keyboard.key("n", True)
    k.devices.keyboard.key("n", False)
    k.step()
    assert k.waiting and k.state.frame.scene == "clifford-torus"
    assert k.window.requests[-1].gpu == "mesh hopf"
    return params


def _press(k, key, frames):
    k.devices.keyboard.key(key, True)
    for _ in range(frames):
        k.step()
    k.devices.keyboard.key(key, False)
    k.step()


def test_the_held_picture_turns_with_the_controls(kiosk):
    """q (theta1) and l (the controller's button 3, fed here by the keyboard: the sensor
    comes closer) held while the visitor waits: the scene on screen turns
    and its sensor moves, redrawn each frame; the scene they asked for still comes first."""
    k = kiosk
    _wait_for_the_next_scene(k)
    before = k.window.requests[-1].view
    _press(k, "q", 5)
    turned = k.window.requests[-1].view
    assert k.waiting and k.window.requests[-1].gpu == "mesh hopf"
    moved = math.remainder(turned.angles[0] - before.angles[0], 2 * math.pi)
    assert math.degrees(moved) > 20, "theta1 follows the key (60 degrees a second)"
    assert turned.angles[1:] == before.angles[1:]
    views = [r.view.angles[0] for r in k.window.requests[-6:]]
    assert len(set(views)) > 3, "redrawn as it turns, not once at the end"
    _press(k, "l", 5)
    assert k.window.requests[-1].view.sensor_r != turned.sensor_r, "the sensor moves too"
    assert k.content.preparer.pending()[0].scene == "clifford-torus"


def test_home_takes_the_held_picture_to_its_scenes_start(kiosk):
    k = kiosk
    params = _wait_for_the_next_scene(k)
    _press(k, "q", 5)
    start = k.state.start_view("hopf", params)
    turned = k.window.requests[-1].view.angles[0]
    assert abs(math.remainder(turned - start.angles[0], 2 * math.pi)) > 0.3
    _press(k, "space", 1)  # button 1: home
    view = k.window.requests[-1].view
    assert view.angles == pytest.approx(start.angles)
    assert view.sensor_r == pytest.approx(start.sensor_r)


def test_the_held_caption_gives_way_to_the_preparing_notice(kiosk):
    """The attract caption ("moves closer ...") told of a moment that is over: the notice
    takes its place, and the tags it named go with it; the title still names what is shown."""
    k = kiosk
    k.step()
    shown = k.window.requests[-1].hud
    assert shown.caption and shown.caption != PREPARING
    _wait_for_the_next_scene(k)
    for _ in range(3):
        k.step()
        hud = k.window.requests[-1].hud
        title = scenes.get("clifford-torus").title
        assert hud.caption == PREPARING.replace("{title}", title)
        assert hud.note == "" and hud.tags == ()
        assert hud.title == shown.title


def test_health_and_status_name_the_scene_shown_and_the_one_prepared(kiosk, tmp_path, capsys):
    k = kiosk
    _wait_for_the_next_scene(k)
    for _ in range(5):
        k.step()
    k.report(k.clock())
    health = json.loads((tmp_path / "health.json").read_text())
    assert health["scene"] == "hopf", "the scene on screen"
    assert health["preparing"] == "clifford-torus"
    assert health["waiting_s"] > 0
    main(["status", "--file", str(tmp_path / "health.json"), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert (out["scene"], out["preparing"]) == ("hopf", "clifford-torus")
    main(["status", "--file", str(tmp_path / "health.json")])
    text = capsys.readouterr().out
    assert re.search(r"scene +hopf\n", text)
    assert re.search(r"preparing +clifford-torus \(a visitor has waited \d+ s\)\n", text)
    # it came: the scene shown is the one asked for, nothing is prepared for a visitor
    while k.waiting:
        k.content.collect(k.clock(), k.parts.started)
        k.step()
    k.report(k.clock())
    health = json.loads((tmp_path / "health.json").read_text())
    assert health["scene"] == "clifford-torus" and health["waiting_s"] is None


def test_the_loop_runs_at_full_rate_while_the_held_picture_turns(tmp_path, monkeypatch):
    """A held picture that stands still is redrawn every HOLD_FRAME_S (the CPU goes to the
    preparing); one the visitor turns, at the loop's full rate."""
    k = _kiosk(tmp_path, monkeypatch, tick=0.001)
    _wait_for_the_next_scene(k)
    monkeypatch.setattr(k.content, "collect", lambda now, started: None)  # it does not come
    sleeps = []
    monkeypatch.setattr(frame_loop.time, "sleep", lambda s: sleeps.append((k.frames, s)))

    def press_q_after_three_frames():
        if k.frames == 3:
            k.devices.keyboard.key("q", True)
        return False

    k.run(max_frames=6, until=press_q_after_three_frames)
    assert k.waiting and k.window.requests[-1].gpu == "mesh hopf"
    held_back = [frame for frame, s in sleeps if s > frame_loop.HOLD_FRAME_S / 2]
    assert held_back == [1, 2, 3], sleeps  # then vsync (or fps_limit) paces it
