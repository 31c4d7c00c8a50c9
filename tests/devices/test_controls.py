"""Controls that reach everything (issue 14): with the shipped mapping the 6-axis controller alone
turns θ1..θ6 and moves the sensor, driven through the real serial backend by the simulated
controller on a pty; held buttons are rates; next-scene buttons; the keyboard's next-scene key."""

from __future__ import annotations

import dataclasses
import math

import pytest

from exhibit.devices.base import Event, Kind, State
from exhibit.devices.config import load_config, parse_config
from exhibit.devices.keyboard import KeyboardBackend, key_name
from exhibit.devices.mapping import PARAMS, Mapper
from exhibit.geometry.view import ViewState

DEG = math.pi / 180


def only(device: str):
    """The shipped mapping with the bindings of one device only."""
    config = load_config()
    mapping = config.mapping
    binds = tuple(b for b in mapping.bindings if b.device == device)
    return dataclasses.replace(mapping, bindings=binds)


def params_of(view: ViewState) -> list[float]:
    return [*view.angles, view.sensor_r]


def test_the_controller_alone_reaches_all_six_angles_and_the_sensor(loop, controller, sim, clock):
    """Each stick, then the sensor buttons, over the real protocol: every parameter moves, and
    nothing else but the one asked for."""
    mapper = Mapper(only("controller"))
    loop.until(lambda: controller.state is State.CONNECTED)
    view = ViewState()

    def drive(seconds: float) -> ViewState:
        nonlocal view
        for _ in range(round(seconds / 0.01)):
            loop.step()
            view = mapper.apply(view, loop.events, clock())
            loop.events.clear()
        return view

    for axis in range(6):
        before = params_of(view)
        sim.set_axes([0.8 if i == axis else 0.0 for i in range(6)])
        drive(0.5)
        sim.set_axes([0.0] * 6)
        drive(0.3)
        moved = [i for i, (a, b) in enumerate(zip(before, params_of(view))) if abs(a - b) > 1e-9]
        assert moved == [axis], (PARAMS[axis], moved)
        # 0.5 s at 0.8 deflection, square curve after a 3 % dead zone, 90 degrees/s: ~26 degrees
        assert 15 * DEG < view.angles[axis] - before[axis] < 35 * DEG

    sim.set_buttons(0b0100)  # button 3 held: the sensor comes closer
    drive(1.0)
    sim.set_buttons(0)
    drive(0.3)
    assert view.sensor_r == pytest.approx(0.2, abs=0.03)  # 0.2 r/s for about a second
    closest = view
    sim.set_buttons(0b0100)
    drive(3.0)
    assert view.sensor_r == pytest.approx(0.5)  # held on: stops at the closest, distance 2
    sim.set_buttons(0b1000)  # button 4 held: back out, to rest at infinity
    drive(3.0)
    sim.set_buttons(0)
    drive(0.3)
    assert view.sensor_r == 0.0 and closest.sensor_r > 0
    assert view.angles == closest.angles  # the buttons moved the sensor only


def test_controller_buttons_home_and_next_scene():
    m = Mapper(only("controller"))
    press = [Event(1.0, "controller", Kind.BUTTON, i, 1.0) for i in range(4)]
    assert [m.switches_scene(e) for e in press] == [False, True, False, False]
    assert not m.switches_scene(Event(1.0, "controller", Kind.BUTTON, 1, 0.0))  # a release
    turned = ViewState(angles=(0.5,) * 6, sensor_r=0.3)
    assert m.apply(turned, [press[0]], 1.0).angles == (0.0,) * 6  # home


def test_a_held_button_is_a_rate_until_its_release_stamp():
    m = Mapper(
        parse_config(
            {
                "mapping": {
                    "bind": [
                        {"device": "d", "input": "button 3", "param": "sensor", "rate": 0.1},
                        {
                            "device": "d",
                            "input": "button 4",
                            "param": "theta2",
                            "rate": 30,
                            "invert": True,
                        },
                    ]
                }
            },
            "t.toml",
        ).mapping
    )
    v = m.apply(
        ViewState(),
        [Event(10.0, "d", Kind.BUTTON, 2, 1.0), Event(10.0, "d", Kind.BUTTON, 3, 1.0)],
        10.0,
    )
    for frame in range(1, 11):  # frames at 10 Hz for a second
        v = m.apply(v, [], 10.0 + frame / 10)
    assert v.sensor_r == pytest.approx(0.1) and v.angles[1] == pytest.approx(-30 * DEG)
    # released at 11.3 by its stamp, though the frame is at 11.4: 0.3 s more, no more
    v = m.apply(
        v, [Event(11.3, "d", Kind.BUTTON, 2, 0.0), Event(11.3, "d", Kind.BUTTON, 3, 0.0)], 11.4
    )
    assert v.sensor_r == pytest.approx(0.13) and v.angles[1] == pytest.approx(-39 * DEG)
    assert m.apply(v, [], 20.0) is v
    # a rate button is not a scene switch, a button bound to nothing is
    assert not m.switches_scene(Event(0, "d", Kind.BUTTON, 2, 1.0))
    assert m.switches_scene(Event(0, "d", Kind.BUTTON, 7, 1.0))


@pytest.mark.parametrize(
    "bind, fragment",
    [
        (
            {"input": "button 1"},
            'a button takes either action = "home" or "next-scene", or a param',
        ),
        ({"input": "button 1", "param": "sensor", "action": "home"}, "a button takes either"),
        (
            {"input": "button 1", "param": "sensor", "step": 0.1},
            "mapping.bind[0].step: only for deltas; a button takes rate",
        ),
        (
            {"input": "button 1", "param": "sensor", "curve": 2},
            "mapping.bind[0].curve: only for axes; a button takes rate",
        ),
        (
            {"input": "button 1", "param": "sensor", "rate": 30},
            "mapping.bind[0].rate: must lie in [0, 20] for sensor",
        ),
        ({"input": "delta 1", "action": "next-scene"}, "mapping.bind[0].action: only buttons"),
        (
            {"input": "button 1", "action": "next"},
            "mapping.bind[0].action: must be 'home', 'next-scene', 'language' or 'listen'",
        ),
    ],
)
def test_bad_button_bindings_name_the_key(bind, fragment):
    from exhibit.devices.base import DeviceError

    with pytest.raises(DeviceError) as info:
        parse_config({"mapping": {"bind": [{"device": "d", **bind}]}}, "museum.toml")
    assert fragment in str(info.value), str(info.value)


def test_the_keyboard_has_a_next_scene_key(clock):
    kb = KeyboardBackend(name="keyboard", clock=clock).open()
    m = Mapper(only("keyboard"))
    kb.key("n", True)
    kb.key("n", False)
    kb.key("space", True)
    kb.key("l", True)
    kb.key("v", True)
    events = kb.poll()
    assert [m.switches_scene(e) for e in events] == [True, False, False, False, False]
    assert m.pressed(events[-2:-1], "language") and not m.pressed(events[:-2], "language")
    assert m.pressed(events[-1:], "listen") and not m.pressed(events[:-1], "listen")
    assert m.without(events, "listen") == events[:-1]  # a listen press is no takeover
    assert kb.capabilities.buttons == 4


def test_the_keyboard_reaches_every_parameter_with_the_shipped_mapping(clock):
    kb = KeyboardBackend(name="keyboard", clock=clock).open()
    m = Mapper(only("keyboard"))
    view = ViewState()
    for i, plus in enumerate("qwertyu"):
        before = params_of(view)
        kb.key(plus, True, t=clock())
        view = m.apply(view, kb.poll(), clock())
        clock.advance(0.25)
        kb.key(plus, False, t=clock())
        view = m.apply(view, kb.poll(), clock())
        moved = [j for j, (a, b) in enumerate(zip(before, params_of(view))) if a != b]
        assert moved == [i], (plus, moved)


class FakeGlfw:
    """The few names key_name uses: printable keys have layout names, the rest codes."""

    KEY_SPACE, KEY_ESCAPE, KEY_UP, KEY_DOWN, KEY_LEFT, KEY_RIGHT = 32, 256, 265, 264, 263, 262

    @staticmethod
    def get_key_name(key, scancode):
        return {81: "q", 78: "N"}.get(key)


def test_window_key_names_match_the_keyboard_backend():
    assert key_name(FakeGlfw, 81) == "q" and key_name(FakeGlfw, 78) == "n"
    assert key_name(FakeGlfw, 32) == "space" and key_name(FakeGlfw, 265) == "up"
    assert key_name(FakeGlfw, 999) is None


# ---------------------------------------------------------------- the staff viewer's keys


def test_the_staff_viewer_reads_the_same_keys_as_the_kiosk(clock):
    """A key sequence gives the same views in the viewer as through the kiosk's keyboard://."""
    from exhibit.commands._staff_viewer import StaffControls

    home = ViewState(angles=(0.1, -0.2, 0, 0, 0, 0))
    staff = StaffControls(load_config(), home, clock=clock)
    kb = KeyboardBackend(name="keyboard", clock=clock).open()
    kiosk = Mapper(only("keyboard"))
    a = b = home
    for name, pressed in [
        ("q", True),
        ("u", True),
        ("q", False),
        ("d", True),
        ("u", False),
        ("d", False),
        ("h", True),
        ("h", False),
    ]:
        staff.key(name, pressed)
        kb.key(name, pressed)
        a, b = staff.step(a, clock()), kiosk.apply(b, kb.poll(), clock())
        clock.advance(0.2)
    assert a == b
    assert a.angles[0] > home.angles[0] and a.angles[2] < 0 and a.angles[5] < 0
    assert a.sensor_r > 0 and not staff.depth_colour  # d turns theta3, it no longer colours
    staff.key("space", True)
    assert staff.step(a, clock()) == home  # home is the view the viewer opened with
    staff.key("q", True, frozenset({"ctrl"}))  # a shortcut, not a knob
    clock.advance(0.5)
    assert staff.step(home, clock()) == home


def test_the_staff_viewer_loop_takes_keys_from_the_window():
    """The viewer hears the window's toolkit-neutral events (exhibit.render.target)."""
    from exhibit.commands import _staff_viewer as _viewer
    from exhibit.render.options import RenderOptions
    from exhibit.render.target import Focus, Key

    drawn = []
    script = {
        2: [Key("q", True)],
        10: [Focus(False)],
        12: [Key("q", True)],
        20: [Key("q", False), Key("c", True)],
        25: [Key("escape", True)],
    }

    class FakeWindow:
        should_close, handler = False, None

        def set_input(self, handler):
            self.handler = handler

        def draw(self, request):
            drawn.append((request.view, request.options.depth_colour))

        def swap(self):
            for event in script.get(len(drawn), ()):
                self.handler(event)
            if len(drawn) > 100:
                raise AssertionError("Escape did not close the viewer")

    _viewer.run(FakeWindow(), None, ViewState(), None, load_config(), RenderOptions())
    assert len(drawn) == 25  # Escape after the 25th frame ends the loop
    assert drawn[1][0].angles[0] == 0 and drawn[9][0].angles[0] > 0  # q held turns theta1
    assert drawn[11][0].angles[0] == drawn[10][0].angles[0]  # focus lost: q let go
    assert drawn[20][0].angles[0] == drawn[-1][0].angles[0]  # released: it stops
    assert not drawn[19][1] and drawn[20][1]  # c: depth colour on


# ---------------------------------------------------------------- monitor shows the buttons


def test_monitor_shows_button_presses_held_and_tapped(tmp_path, capsys):
    """A tap shorter than the gap between two lines still shows once; a held button shows on
    every line while held, with what the shipped mapping makes it do."""
    import json

    from exhibit.cli import main

    script = tmp_path / "buttons.txt"
    script.write_text(
        "wait 0.4\nbuttons 2\nwait 0.03\nbuttons\nwait 0.5\nbuttons 3\nwait 0.6\nbuttons\n"
    )
    assert (
        main(
            [
                "monitor",
                "--device",
                f"controller=sim://controller?script={script}",
                "--json",
                "--duration",
                "2.2",
                "--rate",
                "5",
            ]
        )
        == 0
    )
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    seen = [
        [(b["device"], b["button"], b["does"], b["held"]) for b in line["buttons"]]
        for line in lines
    ]
    taps = [s for s in seen if any(b[:3] == ("controller", 2, "next-scene") for b in s)]
    assert len(taps) == 1, seen  # the 30 ms tap, between two lines: on exactly one
    held = [s for s in seen if any(b[:3] == ("controller", 3, "sensor +") for b in s)]
    assert 2 <= len(held) <= 4, seen  # 0.6 s held at 5 lines a second
    assert all(b[3] for s in held[:-1] for b in s)
    assert seen[0] == [] and seen[-1] == []
    assert lines[-1]["sensor_r"] > 0.05  # and the held button moved the sensor


def test_monitor_text_line_names_the_buttons():
    from exhibit.commands.monitor import text_line

    s = {
        "angles_deg": [0.0] * 6,
        "sensor_r": 0.0,
        "sensor_distance": None,
        "idle_s": 0.5,
        "devices": {"controller": "connected"},
        "buttons": [{"device": "controller", "button": 1, "held": True, "does": "home"}],
    }
    assert text_line(s).endswith("| idle 0.5 s | controller button 1 (home, held)")
    assert text_line({**s, "buttons": []}).endswith("| idle 0.5 s")


# ---------------------------------------------------------------- the kiosk's scene buttons


def test_in_the_kiosk_only_the_next_scene_button_changes_scene(tmp_path):
    """With the shipped controller mapping: button 2 moves on, buttons 3 and 4 move the sensor
    and leave the scene, button 1 goes home."""
    from exhibit import scenes
    from exhibit.timelines.file import load_timeline
    from exhibit.timelines.playlist import Playlist
    from exhibit.kiosk.state import VISITOR, KioskState

    path = tmp_path / "t.toml"
    path.write_text(
        'scene = "hopf"\n[[keyframe]]\nt = 0\n[[keyframe]]\nt = 10\nangles = [90, 0, 0, 0, 0, 0]\n'
    )
    state = KioskState(
        Playlist([load_timeline(path, scenes.get)]),
        Mapper(only("controller")),
        ("hopf", "collision"),
        idle_timeout_s=30.0,
        blend_s=2.0,
        now=0.0,
    )

    def button(t, index, value=1.0):
        return Event(t, "controller", Kind.BUTTON, index, value)

    frame = state.update([button(1.0, 2)], 1.0)  # button 3 held: closer, same scene
    assert frame.mode == VISITOR and frame.scene == "hopf"
    for t in (1.1, 1.2, 1.3, 1.4, 1.5):
        frame = state.update([], t)
    frame = state.update([button(1.5, 2, 0.0)], 1.5)
    assert frame.scene == "hopf" and frame.view.sensor_r == pytest.approx(0.1)
    frame = state.update([button(2.0, 3), button(2.5, 3, 0.0)], 2.5)  # button 4: back out
    assert frame.scene == "hopf" and frame.view.sensor_r == pytest.approx(0.0)
    frame = state.update([button(3.0, 1)], 3.0)  # button 2: the next scene
    assert frame.scene == "collision"
    frame = state.update([button(3.5, 1, 0.0), button(4.0, 0)], 4.0)  # home: same scene
    assert frame.scene == "collision"


def test_monitor_says_when_a_device_changes_state_or_detail():
    from exhibit.commands.monitor import device_changes

    seen = {}
    line = {
        "devices": {"controller": "waiting"},
        "details": {"controller": "waiting for /dev/ttyACM0: No such file or directory"},
    }
    assert device_changes(line, seen) == [
        "device controller: waiting (waiting for /dev/ttyACM0: No such file or directory)"
    ]
    assert device_changes(line, seen) == []  # nothing new: nothing said
    line = {
        "devices": {"controller": "connected"},
        "details": {"controller": "firmware 1.0.0 on /dev/ttyACM0"},
    }
    assert device_changes(line, seen) == [
        "device controller: connected (firmware 1.0.0 on /dev/ttyACM0)"
    ]


def test_the_knob_box_alone_reaches_every_parameter(clock):
    """Knobs 1-7 through the real HID backend (the knob box's layout, a fake hidapi bus) and the
    shipped mapping: each knob moves its own parameter, 5 degrees (sensor: 1/40 of r) a detent."""
    from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice, encode_report
    from exhibit.devices.hid import load_layouts
    from exhibit.devices.hub import DeviceSet

    config = load_config()
    config = dataclasses.replace(
        config, devices={"knobs": config.devices["knobs"]}, mapping=only("knobs")
    )
    layout = load_layouts()["knobbox"]
    dev = FakeHidDevice(0x2341, 0x8037, usage_page=0xFF00, clock=clock, layout=layout)
    devices = DeviceSet(config, clock=clock, hid_api=FakeHidBus([dev])).open()
    mapper, view = Mapper(config.mapping), ViewState()
    try:
        for knob in range(7):
            before = params_of(view)
            dev.push(encode_report(layout, deltas={knob: 2}))
            for _ in range(3):
                clock.advance(0.01)
                view = mapper.apply(view, devices.poll(), clock())
            moved = [i for i, (a, b) in enumerate(zip(before, params_of(view))) if a != b]
            assert moved == [knob], (knob, moved)
    finally:
        devices.close()
    assert view.angles == pytest.approx((10 * DEG,) * 6)
    assert view.sensor_r == pytest.approx(0.05)
