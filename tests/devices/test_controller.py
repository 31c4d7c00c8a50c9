"""The serial controller backend against the simulator, over a real pty, on simulated time."""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exhibit.devices import protocol as p
from exhibit.devices.base import DeviceError, Kind, State
from exhibit.devices.controller import DeviceClock, SerialController
from exhibit.devices.sim import SimController, Step, parse_script
from tests.hypothesis_profiles import examples

from .conftest import FakeClock, Loop


def connected(b):
    return lambda: b.state is State.CONNECTED


def test_handshake_learns_the_firmware(loop, controller):
    assert controller.state is State.CONNECTING
    took = loop.until(connected(controller), what="handshake")
    assert took <= 0.1  # HELLO_REQUEST answered at once: no waiting for a reset
    assert controller.hello.firmware == (1, 1, 0) and controller.hello.n_buttons == 5
    assert controller.capabilities.axes == 6 and controller.capabilities.buttons == 5
    assert "firmware 1.1.0" in controller.detail
    loop.run(1.0)  # idle: heartbeats keep it connected, no events
    assert controller.state is State.CONNECTED and loop.events == []
    assert controller.decoder.rejected == 0 and controller.tracker.lost == 0


def test_axes_and_buttons_become_events_on_change_only(loop, controller, sim):
    loop.until(connected(controller))
    sim.set_axes([0.5, 0, 0, 0, 0, -1])
    sim.set_buttons(0b0101)
    loop.run(0.2)  # 20 identical AXES frames
    by = {(e.kind, e.index): e.value for e in loop.events}
    assert len(loop.events) == 4
    assert by[(Kind.ABS, 0)] == pytest.approx(0.5, abs=1e-4) and by[(Kind.ABS, 5)] == -1.0
    assert by[(Kind.BUTTON, 0)] == 1.0 and by[(Kind.BUTTON, 2)] == 1.0
    assert all(e.device == "controller" for e in loop.events)
    sim.set_axes([0] * 6)
    sim.set_buttons(0)
    loop.run(1.0)
    assert [(e.kind, e.index, e.value) for e in loop.events[4:]] == [
        (Kind.ABS, 0, 0.0),
        (Kind.ABS, 5, 0.0),
        (Kind.BUTTON, 0, 0.0),
        (Kind.BUTTON, 2, 0.0),
    ]


def test_button_5_is_an_event_of_index_4(loop, controller, sim):
    """The fifth button (the "listen" button of default.toml: input = "button 5") arrives as
    bit 4 of AXES, a button event of index 4, pressed and released."""
    loop.until(lambda: controller.calibration is not None, what="boot over")
    sim.set_buttons(0b10000)
    loop.run(0.1)
    sim.set_buttons(0)
    loop.run(0.1)
    assert [(e.kind, e.index, e.value) for e in loop.events] == [
        (Kind.BUTTON, 4, 1.0),
        (Kind.BUTTON, 4, 0.0),
    ]


def test_scripts_press_buttons_1_to_5():
    assert parse_script("buttons 1 2 3 4 5\nbuttons\n") == [
        Step(1, "buttons", (1.0, 2.0, 3.0, 4.0, 5.0)),
        Step(2, "buttons", ()),
    ]
    with pytest.raises(DeviceError, match=r"line 1: button numbers must be 1..5"):
        parse_script("buttons 6\n")


def test_an_older_board_with_four_buttons_still_works(clock, tmp_path):
    """Firmware 1.0.0 says n_buttons = 4 in its HELLO: the host takes the count from there,
    its sticks and buttons 1-4 work as before, and its button 5 simply never comes."""
    s = SimController(tmp_path / "c", clock=clock, firmware=(1, 0, 0), n_buttons=4, sync=True)
    s.plug()
    b = SerialController(name="controller", clock=clock, path=str(s.link)).open()
    loop = Loop(clock, s, [b])
    try:
        loop.until(lambda: b.calibration is not None, what="handshake and boot")
        assert b.hello.firmware == (1, 0, 0) and b.hello.n_buttons == 4
        assert b.capabilities.buttons == 4 and "firmware 1.0.0" in b.detail
        s.set_axes([0, 0.5, 0, 0, 0, 0])
        s.set_buttons(0b11000)  # buttons 4 and 5 held: the old board has no fifth
        loop.run(0.2)
        got = {(e.kind, e.index): e.value for e in loop.events}
        assert got == {(Kind.ABS, 1): pytest.approx(0.5, abs=1e-4), (Kind.BUTTON, 3): 1.0}
        assert b.state is State.CONNECTED and b.decoder.rejected == 0
    finally:
        b.close()
        s.stop()


def test_device_clock_stamps_follow_the_device_not_arrival():
    """Frames sampled 10 ms apart, delivered in bursts of three: stamps 10 ms apart, never later
    than arrival, across the 16-bit wrap."""
    dc = DeviceClock()
    stamps = []
    for i in range(30):
        t_ms = (65500 + 10 * i) & 0xFFFF
        arrival = 50.0 + 0.030 * (i // 3 + 1) + 0.004 * (i // 3 % 2)  # read in jittery bursts
        stamps.append((dc.stamp(t_ms, arrival), arrival))
    gaps = [round(b[0] - a[0], 6) for a, b in zip(stamps, stamps[1:])]
    assert all(g >= 0 for g in gaps)  # the first burst cannot know the delay yet, but never
    assert all(abs(g - 0.010) < 1e-3 for g in gaps[3:]), gaps  # steps back; then 10 ms apart
    assert all(s <= a + 1e-12 for s, a in stamps)


def test_unplug_releases_and_replug_resumes_within_2_s(loop, controller, sim, clock):
    loop.until(connected(controller))
    sim.set_axes([0, 0.75, 0, 0, 0, 0])
    sim.set_buttons(0b1000)
    loop.until(lambda: len(loop.events) == 2, what="axes")
    held = len(loop.events)
    sim.unplug()
    loop.step()
    assert controller.state is State.LOST
    assert [(e.kind, e.index, e.value) for e in loop.events[held:]] == [
        (Kind.ABS, 1, 0.0),
        (Kind.BUTTON, 3, 0.0),
    ]  # nothing keeps spinning the view
    assert controller._port is None  # no descriptor kept for a device that is gone
    loop.run(3.0)  # absent for a while: retried by name, nothing else stalls
    assert controller.state is State.LOST and "waiting for" in controller.detail
    sim.plug()  # plugged in again: new /dev/pts, same stable name
    took = loop.until(connected(controller), what="reconnect")
    assert took <= 2.0
    assert controller.reconnects == 1
    loop.run(0.1)
    assert loop.events[-1].kind is Kind.BUTTON and loop.events[-1].value == 1.0  # held again
    assert controller.tracker.lost == 0


def test_link_status_counts_a_repeat_and_a_swap_as_such_not_as_losses(loop, controller, sim):
    """The last frame again, then the next two swapped: 0 lost (it used to say 511)."""
    loop.until(connected(controller))
    loop.run(0.2)
    n = sim._seq  # the number of the simulator's next frame
    sim.inject(p.encode_frame(p.Heartbeat(), n - 1))
    sim.inject(p.encode_frame(p.Heartbeat(), n + 1) + p.encode_frame(p.Heartbeat(), n))
    sim._seq = (n + 2) & 0xFF
    loop.run(0.5)
    link = controller.status()["link"]
    assert (link["lost_frames"], link["duplicates"], link["reordered"]) == (0, 1, 1)


@pytest.mark.parametrize("cut", [1, 2, 5, 10, 16])
def test_unplug_in_the_middle_of_a_frame(loop, controller, sim, cut):
    """A frame cut at any byte by the unplug is never accepted, nor glued to the next one."""
    loop.until(connected(controller))
    frame = p.encode_frame(p.Axes(7, (1000,) * 6, 1), 99)
    sim.inject(frame[:cut])
    loop.step()
    sim.unplug()
    loop.step()
    sim.plug()
    sim.inject(frame[cut:])  # the rest arrives after the reconnect: still not a frame
    loop.until(connected(controller))
    loop.run(0.5)
    assert not any(e.kind is Kind.ABS for e in loop.events)
    assert controller.decoder.frames_ok > 0


def test_missing_port_is_waited_for(clock, tmp_path):
    link = tmp_path / "exhibit-controller"
    b = SerialController(name="c", clock=clock, path=str(link)).open()
    loop = Loop(clock, None, [b])
    loop.run(1.0)
    assert b.state is State.WAITING and str(link) in b.detail  # never connected: not "lost"
    assert b.status()["missing_s"] == pytest.approx(1.0, abs=0.02)
    s = SimController(link, clock=clock, sync=True)
    s.plug()
    loop.sim = s
    try:
        assert loop.until(connected(b)) <= 2.0
    finally:
        b.close()
        s.stop()


def test_silence_marks_lost_then_reopens(loop, controller, sim):
    loop.until(connected(controller))
    sim.hang(3.0)
    took = loop.until(lambda: controller.state is State.LOST, what="lost")
    assert 0.9 <= took <= 1.3  # four heartbeat periods without a frame
    assert "silent" in controller.detail
    loop.until(connected(controller), limit=4.0)


def test_watchdog_reset_is_a_restart_not_a_loss(loop, controller, sim):
    loop.until(connected(controller))
    sim.set_axes([0.2] * 6)
    loop.until(lambda: len(loop.events) == 6, what="axes")
    n = len(loop.events)
    assert controller.send(p.WatchdogTest())
    loop.until(lambda: sim.resets == 1, what="watchdog reset")
    loop.run(0.5)
    assert controller.state is State.CONNECTED
    assert controller.tracker.restarts == 1 and controller.tracker.lost == 0
    after = [(e.index, e.value) for e in loop.events[n:] if e.kind is Kind.ABS]
    assert after[:6] == [(i, 0.0) for i in range(6)]  # released on the restart's HELLO ...
    assert after[6:] and after[6][1] == pytest.approx(0.2, abs=1e-4)  # ... held again after it


def test_calibrate_command_round_trip(loop, controller, sim):
    loop.until(connected(controller))
    controller.send(p.Calibrate())
    loop.until(
        lambda: (
            controller.calibration is not None
            and controller.calibration.reason is p.CalibrationReason.HOST
        )
    )
    assert sim.rx_ok >= 2 and sim.rx_rejected == 0  # hello request and calibrate


def test_wrong_protocol_version_is_named_and_never_connects(clock, tmp_path):
    s = SimController(tmp_path / "c", clock=clock, version=2, sync=True)
    s.plug()
    b = SerialController(name="c", clock=clock, path=str(s.link)).open()
    loop = Loop(clock, s, [b])
    try:
        s.set_axes([0.5] * 6)
        loop.run(3.0)
        assert b.state is not State.CONNECTED and loop.events == []
        assert "protocol version 2" in b.detail and "speaks 1" in b.detail
        assert b.decoder.frames_ok == 0 and b.decoder.rejected > 0
    finally:
        b.close()
        s.stop()


def test_flood_at_full_baud_costs_each_poll_a_bounded_amount(loop, controller, sim):
    loop.until(connected(controller))
    sim.inject(random.Random(5).randbytes(60_000))  # as much garbage as the pty holds
    assert sim.dropped_bytes < 60_000 - 2 * controller.max_read
    before = controller.decoder.bytes_skipped + controller.decoder.pending
    controller.poll()
    consumed = controller.decoder.bytes_skipped + controller.decoder.pending - before
    assert 0 < consumed <= controller.max_read
    sim.inject(b"\x00")
    sim.set_axes([0, 0, 0.3, 0, 0, 0])
    loop.until(lambda: any(e.kind is Kind.ABS for e in loop.events), what="axes after flood")
    assert controller.state is State.CONNECTED


garbage = st.one_of(
    st.just(b""),
    st.binary(min_size=1, max_size=60),
    st.binary(max_size=40).map(lambda b: b + b"\x00"),
)


@settings(
    max_examples=examples(40),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    st.lists(
        st.tuples(garbage, st.lists(st.integers(-32767, 32767), min_size=6, max_size=6)),
        min_size=1,
        max_size=12,
    )
)
def test_every_frame_between_garbage_is_recovered_and_none_invented(tmp_path_factory, chunks):
    """Garbage before a frame destroys it only if it does not end in a delimiter; every other
    frame comes through unchanged, and nothing else does."""
    clock = FakeClock()
    s = SimController(tmp_path_factory.mktemp("fuzz") / "c", clock=clock, sync=True)
    s.plug()
    b = SerialController(name="c", clock=clock, path=str(s.link)).open()
    try:
        loop = Loop(clock, s, [b])
        loop.until(connected(b))
        s.hang(1e6)  # the simulator stops talking; the test writes the line itself
        s.inject(b"\x00")
        expected = []
        for i, (junk, axes) in enumerate(chunks):
            s.inject(junk + p.encode_frame(p.Axes(10 * i, tuple(axes), 0), i))
            if not junk or junk.endswith(b"\x00"):
                expected.append(tuple(axes))
        frames = [
            f
            for f in b.decoder.feed(b._port.read(1 << 16))
            if isinstance(f, p.Frame) and isinstance(f.message, p.Axes)
        ]
        assert [f.message.axes for f in frames] == expected
    finally:
        b.close()
        s.stop()
