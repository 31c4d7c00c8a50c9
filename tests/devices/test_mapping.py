"""The mapping from events to the seven parameters, the activity detector, and the config."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from exhibit.devices.base import DeviceError, Event, Kind
from exhibit.devices.config import load_config, parse_config
from exhibit.devices.mapping import ActivityDetector, Mapper, shape
from exhibit.geometry.view import ViewState

DEG = math.pi / 180
ROOT = Path(__file__).resolve().parents[2]


def cfg(binds, **mapping):
    return parse_config({"mapping": {"bind": binds, **mapping}}, "test.toml").mapping


def ev(t, kind, index, value, device="d"):
    return Event(t, device, Kind(kind), index, value)


def test_knob_detents_are_angle_steps_and_invert():
    m = Mapper(
        cfg(
            [
                {"device": "d", "input": "delta 1", "param": "theta1", "step": 5},
                {"device": "d", "input": "delta 2", "param": "theta4", "step": 2, "invert": True},
            ]
        )
    )
    v = m.apply(ViewState(), [ev(0, "rel", 0, 3), ev(0, "rel", 1, 2), ev(0, "rel", 0, -1)], 0.0)
    assert v.angles[0] == pytest.approx(10 * DEG) and v.angles[3] == pytest.approx(-4 * DEG)
    assert v.angles[1:3] == (0.0, 0.0)


def test_axis_is_a_rate_integrated_over_event_time():
    m = Mapper(cfg([{"device": "d", "input": "axis 2", "param": "theta2", "rate": 90}]))
    v = ViewState()
    v = m.apply(v, [ev(10.0, "abs", 1, 0.5)], 10.0)
    assert v.angles[1] == 0.0
    v = m.apply(v, [], 10.4)  # held for 0.4 s at half deflection: 18 degrees
    assert v.angles[1] == pytest.approx(18 * DEG)
    # released at 10.5 (by the event's stamp) though the frame is drawn at 10.7
    v = m.apply(v, [ev(10.5, "abs", 1, 0.0)], 10.7)
    assert v.angles[1] == pytest.approx(22.5 * DEG)
    assert m.apply(v, [], 20.0) is v  # nothing held: the same object, no work


def test_dead_zone_and_curve_shape_the_deflection():
    assert shape(0.05, 0.1, 1) == 0.0
    assert shape(0.1 + 1e-9, 0.1, 1) == pytest.approx(0.0, abs=1e-8)  # no jump at the edge
    assert shape(0.55, 0.1, 1) == pytest.approx(0.5)
    assert shape(-0.55, 0.1, 2) == pytest.approx(-0.25)
    assert shape(1.0, 0.1, 3) == 1.0
    m = Mapper(
        cfg(
            [
                {
                    "device": "d",
                    "input": "axis 1",
                    "param": "theta3",
                    "rate": 100,
                    "dead_zone": 0.2,
                    "curve": 2,
                }
            ]
        )
    )
    v = m.apply(ViewState(), [ev(0, "abs", 0, -0.6)], 0.0)
    v = m.apply(v, [], 0.5)
    v = m.apply(v, [], 1.0)
    assert v.angles[2] == pytest.approx(-25 * DEG)
    v = m.apply(v, [], 3.0)  # a stalled loop (2 s) moves at most MAX_DT's worth: no lurch
    assert v.angles[2] == pytest.approx(-37.5 * DEG)


def test_angles_wrap_and_limits_hold_without_jumps():
    m = Mapper(
        cfg(
            [
                {"device": "d", "input": "delta 1", "param": "theta1", "step": 100},
                {"device": "d", "input": "delta 2", "param": "theta2", "step": 100},
            ],
            limits={"theta2": [-180, 0]},
        )
    )
    v = m.apply(ViewState(), [ev(0, "rel", 0, 2), ev(0, "rel", 1, -3)], 0.0)
    assert v.angles[0] == pytest.approx(-160 * DEG)  # 200 degrees wraps
    assert v.angles[1] == pytest.approx(-180 * DEG)  # held at the limit
    outside = ViewState(angles=(0, 0.5, 0, 0, 0, 0))  # put there by an attract timeline
    w = m.apply(outside, [ev(0, "rel", 1, 0.001)], 0.0)
    assert w.angles[1] == pytest.approx(0.5)  # not pulled in, not pushed further out
    w = m.apply(outside, [ev(0, "rel", 1, -0.001)], 0.0)
    assert w.angles[1] == pytest.approx(0.5 - 0.1 * DEG)  # may move back towards the range


def test_sensor_moves_in_r_reaches_infinity_and_stops_at_the_minimum_distance():
    m = Mapper(
        cfg(
            [{"device": "k", "input": "delta 7", "param": "sensor", "step": 0.025}],
            sensor_min_distance=2.0,
        )
    )
    v = ViewState()
    v = m.apply(v, [ev(0, "rel", 6, 8, "k")], 0)
    assert v.sensor_r == pytest.approx(0.2) and v.sensor_distance == pytest.approx(5.0)
    v = m.apply(v, [ev(0, "rel", 6, 100, "k")], 0)
    assert v.sensor_r == 0.5 and v.sensor_distance == 2.0
    v = m.apply(v, [ev(0, "rel", 6, -1000, "k")], 0)
    assert v.sensor_r == 0.0 and v.sensor_distance == math.inf  # infinity, not beyond
    v = m.apply(v, [ev(0, "rel", 6, 1, "k")], 0)
    assert v.sensor_r == pytest.approx(0.025)  # and straight back from it


def test_several_devices_drive_one_parameter_and_home():
    m = Mapper(
        cfg(
            [
                {"device": "knobs", "input": "delta 1", "param": "theta1", "step": 10},
                {"device": "stick", "input": "axis 1", "param": "theta1", "rate": 10},
                {"device": "knobs", "input": "button 7", "action": "home"},
            ],
            home_angles=[0, -90, 0, 0, 0, 0],
            home_sensor_distance=4,
        )
    )
    v = m.apply(ViewState(), [ev(0, "rel", 0, 1, "knobs"), ev(0, "abs", 0, 1.0, "stick")], 0)
    v = m.apply(v, [], 0.5)
    v = m.apply(v, [], 1.0)
    assert v.angles[0] == pytest.approx(20 * DEG)
    v = m.apply(v, [ev(1.0, "button", 6, 1.0, "knobs")], 1.0)
    assert v.angles == pytest.approx((0, -90 * DEG, 0, 0, 0, 0)) and v.sensor_r == 0.25
    other = m.apply(v, [ev(1.0, "rel", 0, 5, "unbound")], 1.0)
    assert other.angles == v.angles


def test_activity_ignores_noise_and_drift_but_sees_people():
    a = ActivityDetector(threshold=0.15)
    t = 0.0
    for i in range(600):  # a minute of jitter around a pot resting at 0.1
        t += 0.1
        a.observe(ev(t, "abs", 0, 0.1 + 0.03 * math.sin(i)))
        a.update(t)
    assert a.last_active is None and a.idle_for(t) == math.inf
    for i in range(3000):  # five minutes of slow drift to 0.6: never a visitor
        t += 0.1
        a.observe(ev(t, "abs", 0, 0.1 + 0.5 * i / 3000))
        a.update(t)
    assert a.last_active is None
    a.observe(ev(t, "abs", 0, -0.6))  # someone pushes the stick the other way
    assert a.last_active == t
    for _ in range(50):  # and holds it: a steady deflection keeps counting
        t += 0.1
        a.update(t)
    assert a.idle_for(t) == 0.0
    a.observe(ev(t, "abs", 0, 0.6))
    t += 1.0
    a.observe(ev(t, "rel", 0, 0.0))  # a zero delta is nothing
    a.update(t)
    b = ActivityDetector()
    b.observe(ev(5.0, "rel", 3, -1))
    b.observe(ev(6.0, "button", 0, 0.0))  # a release alone is not a visitor
    assert b.idle_for(8.0) == 3.0


def test_default_config_binds_all_seven_parameters():
    c = load_config()
    params = {b.param for b in c.mapping.bindings if b.param}
    assert params == {"theta1", "theta2", "theta3", "theta4", "theta5", "theta6", "sensor"}
    assert c.mapping.sensor_min_distance == 2.0 and c.devices["knobs"] == "hidraw://2341:8037"


@pytest.mark.parametrize(
    "doc, fragment",
    [
        (
            {"mapping": {"bind": [{"device": "d", "input": "delta 1", "param": "theta7"}]}},
            "mapping.bind[0].param: must be 'theta1', 'theta2'",
        ),
        (
            {"mapping": {"bind": [{"device": "d", "input": "knob 1", "param": "theta1"}]}},
            "mapping.bind[0].input: expected 'axis N', 'delta N' or 'button N'",
        ),
        (
            {"mapping": {"bind": [{"device": "d", "input": "delta 0", "param": "theta1"}]}},
            "mapping.bind[0].input",
        ),
        (
            {
                "mapping": {
                    "bind": [{"device": "d", "input": "delta 1", "param": "theta1", "rate": 3}]
                }
            },
            "mapping.bind[0].rate: only for axes",
        ),
        (
            {
                "mapping": {
                    "bind": [
                        {"device": "d", "input": "axis 1", "param": "theta1", "dead_zone": 1.5}
                    ]
                }
            },
            "mapping.bind[0].dead_zone: must lie in [0, 0.95]",
        ),
        (
            {
                "mapping": {
                    "bind": [{"device": "d", "input": "axis 1", "param": "theta1", "invert": "yes"}]
                }
            },
            "mapping.bind[0].invert: must be true or false",
        ),
        ({"mapping": {"sensor_min_distance": 0}}, "mapping.sensor_min_distance: must lie in [0.05"),
        ({"mapping": {"limits": {"sensor": [0, 1]}}}, "mapping.limits.sensor"),
        (
            {"mapping": {"limits": {"theta2": [0, -180]}}},
            "mapping.limits.theta2: expected [low, high]",
        ),
        (
            {"devices": {"c": {"url": "serail:///dev/x"}}},
            "devices.c.url: device URL 'serail:///dev/x': unknown scheme 'serail'",
        ),
        ({"devices": {"c": {"url": "serial:///dev/x?baud=fast"}}}, "baud='fast' is not a number"),
        (
            {
                "devices": {"c": {"url": "keyboard://"}},
                "mapping": {"bind": [{"device": "k", "input": "axis 1", "param": "theta1"}]},
            },
            "mapping.bind[0].device: no device 'k' (configured: c)",
        ),
        ({"devices": {"c": {"uri": "keyboard://"}}}, "devices.c.uri: unknown key (allowed: url)"),
        (
            {
                "mapping": {
                    "bind": [
                        {"device": "d", "input": "button 1", "param": "theta1", "action": "home"}
                    ]
                }
            },
            'a button takes either action = "home" or "next-scene", or a param',
        ),
        (
            {
                "mapping": {
                    "bind": [{"device": "d", "input": "button 1", "action": "home", "hold_s": 2}]
                }
            },
            'mapping.bind[0].hold_s: only a "language" button waits to be held',
        ),
        (
            {
                "mapping": {
                    "bind": [
                        {"device": "d", "input": "button 1", "action": "language", "hold_s": 0.1}
                    ]
                }
            },
            "mapping.bind[0].hold_s: must lie in [0.5, 10]",
        ),
        (
            {
                "mapping": {
                    "bind": [
                        {
                            "device": "d",
                            "input": "button 1",
                            "action": "language",
                            "hold_s": float("nan"),
                        }
                    ]
                }
            },
            "mapping.bind[0].hold_s",
        ),
    ],
)
def test_bad_configs_name_the_key(doc, fragment):
    with pytest.raises(DeviceError) as info:
        parse_config(doc, "museum.toml")
    assert fragment in str(info.value) and str(info.value).startswith("museum.toml: ")


def test_bad_toml_file_names_the_file(tmp_path):
    f = tmp_path / "devices.toml"
    f.write_text("[mapping\n")
    with pytest.raises(DeviceError, match=r"devices.toml: not valid TOML"):
        load_config(f)
    with pytest.raises(DeviceError, match=r"nope.toml: cannot read"):
        load_config(tmp_path / "nope.toml")


def test_a_wrong_url_is_one_problem_not_one_per_binding():
    """The device is configured, only its URL is wrong: its bindings are not also 'no device'."""
    doc = {
        "devices": {"k": {"url": "keyboard://"}, "c": {"url": "serail:///dev/x"}},
        "mapping": {"bind": [{"device": "c", "input": "axis 1", "param": "theta1"}]},
    }
    with pytest.raises(DeviceError) as info:
        parse_config(doc, "museum.toml")
    assert info.value.problems == [
        "museum.toml: devices.c.url: device URL 'serail:///dev/x': unknown scheme 'serail' "
        "(one of serial://, hid://, hidraw://, sim://, replay://, keyboard://)"
    ]


def test_a_long_press_fires_once_after_hold_s_and_a_press_at_once_still_works():
    """The controller's button 1: home when pressed, the next language once held for 2 s
    (once per press); let go earlier and no language changes."""
    m = Mapper(
        cfg(
            [
                {"device": "d", "input": "button 1", "action": "home"},
                {"device": "d", "input": "button 1", "action": "language", "hold_s": 2},
            ]
        )
    )
    view = ViewState(angles=(1.0,) * 6)
    down = [ev(10.0, "button", 0, 1.0)]
    assert m.apply(view, down, 10.0).angles == (0.0,) * 6  # home at once
    assert not m.pressed(down, "language")
    fired = []
    for t in (10.5, 11.0, 11.99, 12.0, 12.5, 14.0):
        m.apply(view, [], t)
        fired.append(m.pressed([], "language"))
    assert fired == [False, False, False, True, False, False]  # once, at 2 s
    m.apply(view, [ev(14.5, "button", 0, 0.0)], 14.5)
    m.apply(view, [ev(15.0, "button", 0, 1.0)], 15.0)  # a short press
    m.apply(view, [ev(16.0, "button", 0, 0.0)], 16.0)
    assert not any(m.apply(view, [], t) and m.pressed([], "language") for t in (17.0, 20.0))
    assert m.button_role("d", 0) == "home, language (held 2 s)"


def test_the_shipped_controller_switches_language_on_a_long_press_of_home():
    config = load_config(ROOT / "configs" / "devices" / "default.toml").mapping
    m = Mapper(config)
    m.apply(ViewState(), [ev(0.0, "button", 0, 1.0, device="controller")], 0.0)
    m.apply(ViewState(), [], 2.0)
    assert m.pressed([], "language")


@pytest.mark.parametrize(
    "text",
    [
        "delta ²",
        "axis ①",
        "button ⑨",
        "delta ¹⁰",
        "axis ₁",
        "axis ٣",
        "delta ۷",
        "axis ４",
        "axis +1",
        "axis -1",
        "axis 0",
        "axis 257",
        "axis 1e1",
        "axis 0x1",
        "axis 1_0",
        "axis " + "9" * 30,
    ],
)
def test_an_input_number_is_ascii_digits_in_range(text):
    """str.isdigit() accepts "²" and "①" (and int() then fails on them); int() accepts "٣"."""
    doc = {"mapping": {"bind": [{"device": "d", "input": text, "param": "theta1"}]}}
    with pytest.raises(DeviceError) as info:
        parse_config(doc, "museum.toml")
    assert info.value.problems == [
        f"museum.toml: mapping.bind[0].input: expected 'axis N', 'delta N' or 'button N' (N from "
        f"1 to 256, in the digits 0-9), got {text!r}"
    ]


@pytest.mark.parametrize("text", ["delta ²", "axis ①", "axis ٣"])
def test_check_config_and_devices_name_a_unicode_digit_input(tmp_path, capsys, text):
    from exhibit.cli import main

    devices = tmp_path / "devices.toml"
    devices.write_text(
        f'[devices.c]\nurl = "keyboard://"\n[[mapping.bind]]\ndevice = "c"\n'
        f'input = "{text}"\nparam = "theta1"\n',
        encoding="utf-8",
    )
    kiosk = tmp_path / "kiosk.toml"
    kiosk.write_text(f'[devices]\nconfig = "{devices}"\n', encoding="utf-8")
    for argv in (
        ["check-config", str(kiosk)],
        ["devices", "--devices-config", str(devices), "--only"],
    ):
        assert main(argv) == 2
        out, err = capsys.readouterr()
        assert "internal error" not in out + err and "Traceback" not in out + err
        assert f"{devices}: mapping.bind[0].input: " in out + err


def test_input_numbers_at_the_ends_of_the_range_are_accepted():
    doc = {
        "mapping": {
            "bind": [
                {"device": "d", "input": "axis 1", "param": "theta1"},
                {"device": "d", "input": "delta 256", "param": "theta2"},
            ]
        }
    }
    indexes = [b.index for b in parse_config(doc, "museum.toml").mapping.bindings]
    assert indexes == [0, 255]
