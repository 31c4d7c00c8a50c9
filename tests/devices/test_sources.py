"""Keyboard source, record/replay determinism, several devices at once, the URL factory, and
the device commands."""

from __future__ import annotations

import json
import math
import re

import pytest

from exhibit.cli import main
from exhibit.devices.base import DeviceError, Event, Kind
from exhibit.devices.config import parse_config
from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice, encode_report
from exhibit.devices.hid import load_layouts
from exhibit.devices.hub import DeviceSet
from exhibit.devices.keyboard import KeyboardBackend
from exhibit.devices.mapping import Mapper
from exhibit.devices.replay import Recorder, read_recording
from exhibit.devices.url import backend_for_url
from exhibit.geometry.view import ViewState

from .conftest import Loop

DEG = math.pi / 180


def test_keyboard_pairs_of_keys_are_axes_drag_and_scroll_are_deltas(clock):
    kb = KeyboardBackend(name="kb", clock=clock).open()
    kb.key("Q", True)
    kb.key("q", True)  # key repeat: no new event
    kb.key("a", True)  # both keys of the pair: zero
    kb.key("q", False)
    kb.drag(3, 0)
    kb.scroll(-2)
    kb.key("space", True)
    got = [(e.kind, e.index, e.value) for e in kb.poll()]
    assert got == [
        (Kind.ABS, 0, 1.0),
        (Kind.ABS, 0, 0.0),
        (Kind.ABS, 0, -1.0),
        (Kind.REL, 0, 3.0),
        (Kind.REL, 2, -2.0),
        (Kind.BUTTON, 0, 1.0),
    ]
    kb.release_all()
    assert [(e.kind, e.value) for e in kb.poll()] == [(Kind.ABS, 0.0), (Kind.BUTTON, 0.0)]
    assert kb.poll() == [] and kb.capabilities.axes == 7


def test_keyboard_presses_with_ctrl_alt_or_super_are_shortcuts_not_knobs(clock):
    kb = KeyboardBackend(name="kb", clock=clock).open()
    for mods in ({"ctrl"}, {"alt"}, {"super"}, {"ctrl", "shift"}):
        kb.key("q", True, mods=frozenset(mods))
        kb.key("space", True, mods=frozenset(mods))
        kb.key("q", False, mods=frozenset(mods))
        kb.key("space", False, mods=frozenset(mods))
    assert kb.poll() == []
    kb.key("q", True, mods=frozenset({"shift"}))  # Shift+Q is still q
    assert [(e.kind, e.value) for e in kb.poll()] == [(Kind.ABS, 1.0)]
    kb.key("q", False, mods=frozenset({"ctrl"}))  # Ctrl went down while q was held
    assert [(e.kind, e.value) for e in kb.poll()] == [(Kind.ABS, 0.0)]


def session(clock):
    """A scripted knob box and keyboard through a DeviceSet, recorded as it goes."""
    config = parse_config(
        {
            "devices": {"knobs": {"url": "hidraw://2341:8037"}, "kb": {"url": "keyboard://"}},
            "mapping": {
                "bind": [
                    {"device": "knobs", "input": "delta 1", "param": "theta1", "step": 5},
                    {"device": "knobs", "input": "delta 7", "param": "sensor", "step": 0.05},
                    {"device": "kb", "input": "axis 2", "param": "theta2", "rate": 45},
                ]
            },
        },
        "s.toml",
    )
    layout = load_layouts()["knobbox"]
    dev = FakeHidDevice(0x2341, 0x8037, usage_page=0xFF00, clock=clock, layout=layout)
    devices = DeviceSet(config, clock=clock, hid_api=FakeHidBus([dev])).open()
    return config, layout, dev, devices


def test_several_devices_at_once_and_replay_is_deterministic(clock, tmp_path):
    config, layout, dev, devices = session(clock)
    mapper = Mapper(config.mapping)
    rec = Recorder(tmp_path / "s.jsonl", config.devices, clock())
    view = ViewState()
    for i in range(200):
        clock.advance(0.01)
        if i % 20 == 5:
            dev.push(encode_report(layout, deltas={0: 1, 6: 1}))
        if i == 50:
            devices.keyboard.key("w", True)
        if i == 120:
            devices.keyboard.key("w", False)
        events = devices.poll()
        rec.write(events)
        view = mapper.apply(view, events, clock())
    rec.close()
    devices.close()
    assert view.angles[0] == pytest.approx(50 * DEG)
    assert view.angles[1] == pytest.approx(45 * 0.7 * DEG)
    assert view.sensor_r == pytest.approx(0.5)  # 10 detents of 0.05, at the 2.0 minimum

    def replay():
        b = backend_for_url(f"replay://{tmp_path / 's.jsonl'}", "replay", clock=clock).open()
        m, v = Mapper(config.mapping), ViewState()
        views = []
        for _ in range(250):
            clock.advance(0.01)
            v = m.apply(v, b.poll(), clock())
            views.append(v)
        return views

    first, second = replay(), replay()
    assert first == second  # the same ViewStates, frame by frame
    assert first[-1].angles == pytest.approx(view.angles) and first[-1].sensor_r == view.sensor_r


def test_replay_at_double_speed_and_looping(clock, tmp_path):
    f = tmp_path / "r.jsonl"
    rec = Recorder(f, {}, 0.0)
    rec.write([Event(1.0, "k", Kind.REL, 0, 1.0), Event(2.0, "k", Kind.ABS, 1, 0.5)])
    rec.close()
    b = backend_for_url(f"replay://{f}?speed=2&loop=1", clock=clock).open()
    loop = Loop(clock, None, [b])
    loop.run(1.1)  # 2.2 recorded seconds: both events, then the loop releases the axis
    assert [(e.kind, e.value) for e in loop.events] == [
        (Kind.REL, 1.0),
        (Kind.ABS, 0.5),
        (Kind.ABS, 0.0),
    ]
    loop.run(1.0)  # the second pass, released again at its end
    assert [(e.kind, e.value) for e in loop.events[3:]] == [
        (Kind.REL, 1.0),
        (Kind.ABS, 0.5),
        (Kind.ABS, 0.0),
    ]
    assert loop.events[3].t == pytest.approx(loop.events[0].t + 1.001)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("", "line 1: not an exhibit recording"),
        (
            '{"exhibit_recording": 1}\n'
            '{"t": 1, "device": "k", "kind": "spin", "index": 0, "value": 1}\n',
            "line 2: bad event",
        ),
        (
            '{"exhibit_recording": 1}\n'
            '{"t": -1, "device": "k", "kind": "rel", "index": 0, "value": 1}\n',
            "line 2: bad event (time -1.0 is not in [0, 1e7] s)",
        ),
        ('{"exhibit_recording": 1}\nnot json\n', "line 2: bad event"),
    ],
)
def test_bad_recordings_name_the_line(tmp_path, text, fragment):
    f = tmp_path / "bad.jsonl"
    f.write_text(text)
    with pytest.raises(DeviceError, match=re.escape(fragment)):
        read_recording(f)


@pytest.mark.parametrize(
    "url, fragment",
    [
        ("/dev/ttyUSB0", "needs a scheme"),
        ("serial://", "no port path"),
        ("serial:///dev/x?speed=9600", "unknown option 'speed' (allowed: baud)"),
        ("serial:///dev/x?baud=0", "option baud must lie in (0, 4e+06]"),
        ("hid://2341", "expected VID:PID in hex"),
        ("hid://zz41:8037", "expected VID:PID in hex"),
        ("hid:///dev/hidraw0", "use hidraw:///dev/hidraw0"),
        ("hid://1234:5678", "no layout matches 1234:5678"),
        ("hidraw:///dev/hidraw0", "say which layout"),
        ("hidraw://2341:8037?layout=nope", "no layout 'nope'"),
        ("sim://teapot", "no simulated device 'teapot'"),
        ("sim://controller?script=/nonexistent", "script /nonexistent: cannot read"),
        ("keyboard://x", "takes no path"),
        ("replay://", "no file"),
        ("replay://a.jsonl?speed=-1", "option speed must lie in (0, 1000]"),
        ("gopher://x", "unknown scheme 'gopher'"),
    ],
)
def test_bad_urls_are_one_clear_error(url, fragment):
    with pytest.raises(DeviceError, match=re.escape(fragment)):
        backend_for_url(url)


def test_sim_script_errors_name_the_line(tmp_path):
    f = tmp_path / "s.txt"
    f.write_text("axes 0 0 0 0 0 0\nwiggle 3\n")
    with pytest.raises(DeviceError, match=r"s.txt line 2: unknown command 'wiggle'"):
        backend_for_url(f"sim://controller?script={f}")
    f.write_text("axes 0 0 2 0 0 0\n")
    with pytest.raises(DeviceError, match=r"line 1: deflections must lie in \[-1, 1\]"):
        backend_for_url(f"sim://controller?script={f}")
    f.write_text("turn 9 1\n")
    with pytest.raises(DeviceError, match=r"line 1: turn CHANNEL STEPS with channel 1..7"):
        backend_for_url(f"sim://knobbox?script={f}")


def test_a_backend_that_raises_does_not_stop_the_others(clock):
    config, layout, dev, devices = session(clock)

    def broken():
        raise RuntimeError("driver surprise")

    devices.backends[0]._poll = broken
    devices.keyboard.key("w", True)
    events = devices.poll()
    assert [e.device for e in events] == ["kb"]
    status = {s["name"]: s for s in devices.statuses()}
    assert status["knobs"]["state"] == "lost" and "driver surprise" in status["knobs"]["detail"]
    devices.close()


def test_a_backend_that_always_raises_is_logged_once_and_reopened(clock, caplog):
    """Polled for 20 s (2000 polls, a reopen every 2 s): one traceback in the log, the other
    device's events all arrive, and the broken one is reopened again and again."""
    config, layout, dev, devices = session(clock)
    knobs = devices.backends[0]
    opens = []

    def broken():
        raise RuntimeError("driver surprise")

    def reopen():
        opens.append(clock())
        knobs._poll = broken  # the real _open would restore nothing; the bug stays

    knobs._poll, knobs._open = broken, reopen
    got = []
    with caplog.at_level("ERROR", logger="exhibit.devices"):
        for i in range(2000):
            clock.advance(0.01)
            devices.keyboard.key("w", i % 100 < 50)
            got += devices.poll()
    tracebacks = [r for r in caplog.records if r.exc_info]
    assert len(tracebacks) == 1 and "driver surprise" in caplog.text
    assert caplog.text.count("Traceback") == 1
    assert sum(e.device == "kb" for e in got) == 40  # 20 presses and 20 releases
    assert len(opens) >= 9
    status = {s["name"]: s for s in devices.statuses()}
    assert status["knobs"]["detail"].endswith(f"({len(opens) + 1} so far)")
    devices.close()


def test_monitor_shows_a_simulated_controller_moving_the_view(tmp_path, capsys):
    script = tmp_path / "push.txt"
    script.write_text("wait 0.3\naxes 1 0 0 0 0 0\n")
    assert (
        main(
            [
                "monitor",
                "--only",
                "--device",
                f"controller=sim://controller?script={script}",
                "--json",
                "--duration",
                "1.5",
                "--rate",
                "10",
            ]
        )
        == 0
    )
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert lines[-1]["devices"] == {"controller": "connected"}
    assert lines[-1]["angles_deg"][0] > 5 and lines[-1]["idle_s"] is not None
    assert lines[0]["angles_deg"][0] == 0


def test_devices_lists_states(capsys):
    assert (
        main(
            [
                "devices",
                "--only",
                "--device",
                "c=sim://controller",
                "--device",
                "k=sim://powermate",
                "--json",
                "--wait",
                "2",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    states = {s["name"]: s["state"] for s in report["configured"]}
    assert states == {"c": "connected", "k": "connected"}
    assert isinstance(report["serial"], list) and isinstance(report["hid"], list)


def test_record_then_decode_free_replay(tmp_path, capsys):
    out = tmp_path / "rec.jsonl"
    script = tmp_path / "k.txt"
    script.write_text("turn 1 2\nwait 0.1\nturn 1 -1\n")
    assert (
        main(
            [
                "record",
                str(out),
                "--only",
                "--device",
                f"k=sim://knobbox?script={script}",
                "--duration",
                "0.4",
            ]
        )
        == 0
    )
    header, events = read_recording(out)
    assert header["devices"] == {"k": f"sim://knobbox?script={script}"}
    assert [(e.kind, e.value) for e in events] == [(Kind.REL, 2.0), (Kind.REL, -1.0)]


def test_simulate_prints_the_tty_and_speaks_the_protocol(tmp_path):
    import subprocess
    import sys

    import serial

    from exhibit.devices import protocol as p

    proc = subprocess.Popen(
        [sys.executable, "-m", "exhibit", "simulate", "controller", "--duration", "120"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        tty = proc.stdout.readline().strip()
        assert tty.startswith("/dev/pts/")
        port = serial.Serial(tty, 115200, timeout=0.2)
        port.write(p.encode_frame(p.HelloRequest(), 0))
        dec = p.StreamDecoder()
        frames = []
        for _ in range(300):  # 60 s of reads: a hang's backstop, however busy the machine
            frames += [f for f in dec.feed(port.read(256)) if isinstance(f, p.Frame)]
            if any(isinstance(f.message, p.Hello) for f in frames):
                break
        port.close()
        assert any(isinstance(f.message, p.Hello) for f in frames), dec.summary()
    finally:
        proc.terminate()
        proc.communicate(timeout=10)


def test_bad_device_option_is_one_line(cli):
    r = cli("monitor", "--device", "nourl", "--duration", "0.1")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "--device 'nourl': expected NAME=URL" in r.stderr
    r = cli("simulate", "controller", "--script", "/nonexistent/s.txt")
    assert r.returncode == 2 and "/nonexistent/s.txt: cannot read" in r.stderr


def test_bench_input_runs_the_real_path(capsys):
    """The benchmark's plumbing (not its timings): every frame reached the ViewState."""
    assert main(["bench", "input", "--frames", "20", "--decode-frames", "2000", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert set(r["latency_ms"]) == {"p50", "p99", "max", "mean"}
    assert r["decoder_frames_per_s"] > 0 and "goals_met" in r
