"""What the kiosk survives: frames that raise, scenes that fail to build, GLFW errors.

The Kiosk runs here in-process on a fake window and a fake clock (meshes are stand-ins, so no
GL and no mesh builds), except the last test, which shows the every-scene-failed notice in a
real window under Xvfb."""

import json
import logging
import os
import subprocess
import sys

import numpy as np
from PIL import Image

from exhibit.kiosk import app, frame_loop
from exhibit.preparing import jobs
from exhibit.render.window import GlfwErrors
from tests.kiosk.support import ROOT, FakeWindow, kiosk, make_config
from tests.xvfb import unavailable, xvfb
import contextlib


def health(tmp_path):
    return json.loads((tmp_path / "health.json").read_text())


def test_frames_that_raise_are_logged_once_and_the_next_frame_tries_again(
    tmp_path, monkeypatch, caplog
):
    k, notifier = kiosk(tmp_path, monkeypatch)
    k.window.fail = 200
    with caplog.at_level(logging.INFO, logger="exhibit.kiosk"):
        assert k.run(max_frames=300) == 0
    assert caplog.text.count("Traceback") == 1 and "a bug in the renderer" in caplog.text
    assert "more failed frames in the last" in caplog.text  # a count, about every 10 s
    assert sum(r.levelno >= logging.ERROR for r in caplog.records) < 10
    assert len(k.window.drawn) == 100 and k.frames == 100 and k.errors.total == 200
    # The watchdog is pinged every frame, drawn or not; READY once, at the first frame drawn.
    assert notifier.calls.count("watchdog") == 300
    assert notifier.calls.index("ready") > 200 and notifier.calls.count("ready") == 1
    report = health(tmp_path)
    assert 90 <= report["frames"] <= 100 and report["frame_errors"] == 200  # a second ago
    assert report["problems"] == [] and report["fps"] > 0


def test_a_minute_of_nothing_but_failed_frames_exits_for_systemd_to_restart(
    tmp_path, monkeypatch, caplog
):
    k, _ = kiosk(tmp_path, monkeypatch)
    k.window.fail = 10**9
    with caplog.at_level(logging.INFO, logger="exhibit.kiosk"):
        assert k.run(max_frames=10_000) == frame_loop.FAILING_EXIT
    assert 60 <= k.clock() - k.parts.started < 62 and k.frames == 0
    assert caplog.text.count("Traceback") == 1 and "exiting, for systemd" in caplog.text
    assert any("frames failing for" in p for p in health(tmp_path)["problems"])


def test_a_scene_that_fails_to_build_is_skipped_with_its_timelines(tmp_path, monkeypatch, caplog):
    """hopf fails: its attract timeline goes too, so attract mode turns clifford-torus."""
    with caplog.at_level(logging.INFO, logger="exhibit.kiosk"):
        k, _ = kiosk(tmp_path, monkeypatch, broken={"hopf"})
        assert k.run(max_frames=50) == 0
    assert caplog.text.count("Traceback") == 1 and "scene hopf skipped" in caplog.text
    assert k.state.content == ("clifford-torus",) and k.state.playlist.timelines == []
    assert set(k.window.drawn) == {"mesh clifford-torus"} and k.errors.total == 0
    first = k.state.frame.view.angles[0]
    assert k.state.update([], k.clock() + 10).view.angles[0] != first  # it turns
    report = health(tmp_path)
    assert report["scenes_failed"] == [
        {"scene": "hopf", "reason": "RuntimeError: cannot build hopf"}
    ]
    assert any("attract timeline" in p for p in report["problems"])
    assert report["mode"] == "attract" and report["scene"] == "clifford-torus"


def test_buttons_do_nothing_when_no_content_scene_is_left(tmp_path, monkeypatch):
    from exhibit.devices.base import Event, Kind

    k, _ = kiosk(tmp_path, monkeypatch, broken={"clifford-torus"})
    k.state.content = ()  # hopf only shows in its timeline
    frame = k.state.update([Event(k.clock(), "controller", Kind.BUTTON, 0, 1.0)], k.clock())
    assert frame.mode == "visitor" and frame.scene == "hopf"


def test_when_every_scene_fails_the_kiosk_shows_a_notice_and_runs_on(tmp_path, monkeypatch):
    k, notifier = kiosk(tmp_path, monkeypatch, broken=True)
    assert k.state is None
    assert k.run(max_frames=30) == 0
    assert k.window.notices == 30 and k.errors.total == 0 and "ready" in notifier.calls
    report = health(tmp_path)
    assert report["mode"] is None and report["scene"] is None
    assert {f["scene"] for f in report["scenes_failed"]} == {"hopf", "clifford-torus"}
    assert any("no scene could be prepared" in p for p in report["problems"])


def test_glfw_errors_are_logged_once_then_counted(caplog):
    now = [0.0]
    errors = GlfwErrors(every=60, clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger="exhibit.glfw"):
        for i in range(1000):
            now[0] = i * 0.1
            errors(65544, b"X11: something the window system refused")
        errors(65545, "another")
    lines = caplog.text.splitlines()
    assert len(lines) == 3 and errors.last == "(65545) another"
    assert "(600 more times in 60 s)" in lines[1]


NOTICE_RUN = r"""
import sys
from exhibit.preparing import jobs
def build(scene, params, resolution):
    raise RuntimeError("no mesh today")
jobs.build_cached = build
from exhibit.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_the_notice_is_drawn_in_a_real_window(tmp_path):
    kiosk = make_config(tmp_path, "wait 60\n")
    shot = tmp_path / "notice.png"
    with xvfb() as display:
        env = dict(
            os.environ,
            DISPLAY=display,
            EXHIBIT_CACHE_DIR=str(tmp_path / "cache"),
            EXHIBIT_STATE_DIR=str(tmp_path / "state"),
        )
        env.pop("NOTIFY_SOCKET", None)
        result = subprocess.run(
            [
                sys.executable,
                "-c",
                NOTICE_RUN,
                "run",
                "--config",
                str(kiosk),
                "--windowed",
                "--duration",
                "2",
                "--screenshot",
                str(shot),
            ],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
            cwd=ROOT,
        )
    if result.returncode != 0 and "cannot start GLFW" in result.stderr:
        unavailable("no GLFW window on Xvfb")
    assert result.returncode == 0, result.stderr[-3000:]
    assert "no scene could be prepared" in result.stderr
    picture = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert picture.shape == (240, 320)
    assert (picture > 150).sum() > 100  # light text on the dark screen
    assert picture.mean() < 60
    report = json.loads((tmp_path / "state" / "health.json").read_text())
    assert any("no scene could be prepared" in p for p in report["problems"])


def test_a_cut_is_crossfaded_from_the_last_frame_shown(tmp_path, monkeypatch):
    """The playlist looping (a cut): the kiosk captures the frame on screen, then lays it over
    the new frames fading out over CROSSFADE_S; every frame is drawn (never a black one)."""
    k, _ = kiosk(tmp_path, monkeypatch)
    duration = sum(t.duration for t in k.state.playlist.timelines)
    assert k.run(duration=1.5 * duration) == 0
    window = k.window
    assert len(window.drawn) == k.frames
    assert len(window.captured) == 1, "one loop, one crossfade"
    start = next(i for i, f in enumerate(window.fades) if f > 0)
    fading = [f for f in window.fades[start:] if f > 0]
    seconds = (k.clock() - k.parts.started) / k.frames  # per frame, on the fake clock
    assert 0.5 < fading[0] <= 1.0 and fading == sorted(fading, reverse=True)
    assert len(fading) <= app.CROSSFADE_S / seconds + 1
    assert not any(window.fades[:start]) and not any(window.fades[start + len(fading) :])


def test_a_broken_unused_scene_file_stops_nothing_but_is_reported(tmp_path, monkeypatch, capsys):
    """One broken curator's file on the scene path: check-config still says so (exit 2), but
    `exhibit run` runs with the valid scenes and names the file in the log and health file."""
    from exhibit import scenes
    from exhibit.cli import main
    from exhibit.kiosk.config import load_kiosk_config

    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "broken.toml").write_text('name = "broken"\n[surface]\nkind = 3\n')
    monkeypatch.setenv("EXHIBIT_SCENE_PATH", str(folder))
    scenes.load(reload=True)
    try:
        path = make_config(tmp_path, "")
        assert main(["check-config", str(path)]) == 2
        assert str(folder / "broken.toml") in capsys.readouterr().out
        config = load_kiosk_config(path, broken_scenes_ok=True)
        assert any(str(folder / "broken.toml") in p for p in config.scene_problems)

        # exhibit run gets as far as opening its window with that config
        opened = []

        def open_window(config, windowed):
            opened.append(config)
            raise SystemExit(0)

        monkeypatch.setattr(app, "open_window", open_window)
        monkeypatch.setattr("faulthandler.enable", lambda *a, **k: None)  # pytest's stderr
        with contextlib.suppress(SystemExit):
            main(["run", "--config", str(path), "--windowed"])
        assert opened and opened[0].scene_problems == config.scene_problems

        monkeypatch.setattr(
            jobs, "build_cached", lambda scene, params, res: (f"mesh {scene.name}", None)
        )
        ticks = iter(np.arange(1e6) * 0.1)
        k = app.Kiosk(
            config,
            FakeWindow(),
            clock=lambda: float(next(ticks)),
            health_path=tmp_path / "health.json",
        )
        assert k.state is not None
        k.report(k.clock())
        report = health(tmp_path)
        assert any(
            "scene file left out" in p and str(folder / "broken.toml") in p
            for p in report["problems"]
        ), report["problems"]
    finally:
        monkeypatch.delenv("EXHIBIT_SCENE_PATH")
        scenes.load(reload=True)
