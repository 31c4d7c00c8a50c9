"""Device states over time: ``waiting`` (never connected since the start) is told apart from
``lost`` (was connected, went away), and every backend knows how long it has been in its state
and how long its device has been missing, for the health file and `exhibit status --max-lost`."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass

import pytest

from exhibit.devices.base import MISSING, Backend, State
from exhibit.devices.controller import SerialController
from exhibit.devices.fakehid import encode_report
from exhibit.devices.hub import DeviceSet

from .conftest import Loop
from .test_sources import session


@dataclass
class Toy(Backend):
    """A backend whose device comes and goes when a test says so."""

    present: bool = False

    def _open(self) -> None:
        self._poll()

    def _close(self) -> None:
        pass

    def _poll(self) -> list:
        self.state = State.CONNECTED if self.present else State.LOST
        return []


def test_never_connected_is_waiting_then_lost_after_a_connection(clock):
    b = Toy(name="toy", clock=clock)
    assert b.state is State.CLOSED and b.status()["state_s"] is None
    assert b.missing_seconds() is None
    b.open()
    assert b.state is State.WAITING and not b.ever_connected
    clock.advance(5)
    assert b.status()["state"] == "waiting"
    assert b.status()["missing_s"] == b.status()["state_s"] == 5.0
    b.present = True
    b.poll()
    assert b.state is State.CONNECTED and b.ever_connected
    assert b.status()["missing_s"] is None and b.status()["state_s"] == 0.0
    clock.advance(60)
    b.present = False
    b.poll()
    assert b.state is State.LOST  # it was here: lost, not waiting
    clock.advance(2.5)
    assert b.status()["missing_s"] == 2.5 and b.status()["ever_connected"] is True
    b.close()
    assert b.state is State.CLOSED and b.missing_seconds() is None


def test_missing_time_runs_on_through_reconnect_attempts(clock):
    """LOST -> RECONNECTING -> LOST ... (a hung board): the state changes, the absence does not."""
    b = Toy(name="toy", clock=clock, present=True).open()
    clock.advance(1)
    b.state = State.LOST
    for _ in range(10):
        clock.advance(0.5)
        b.state = State.RECONNECTING
        clock.advance(2)
        b.state = State.LOST
    assert b.state_seconds() == 0.0 and b.missing_seconds() == 25.0


def test_a_close_and_reopen_into_the_same_state_continues_it(clock):
    b = Toy(name="toy", clock=clock).open()
    clock.advance(10)
    b.close()
    clock.advance(1)
    b.open()
    assert b.state is State.WAITING and b.state_seconds() == 11.0
    assert b.missing_seconds() == 11.0


def test_a_backend_that_keeps_raising_stays_missing_since_its_first_failure(clock):
    config, layout, dev, devices = session(clock)
    knobs = devices.backends[0]
    assert knobs.state is State.CONNECTED

    def broken():
        raise RuntimeError("driver surprise")

    knobs._poll, knobs._open = broken, broken
    for _ in range(1000):  # 10 s: reopened (and failing) every 2 s
        clock.advance(0.01)
        devices.poll()
    status = {s["name"]: s for s in devices.statuses()}["knobs"]
    assert status["state"] == "lost" and status["missing_s"] == pytest.approx(10.0, abs=0.02)
    devices.close()


def test_a_device_absent_from_the_start_is_waiting_in_the_device_set(clock):
    config, layout, dev, _ = session(clock)
    dev.unplug()
    from exhibit.devices.fakehid import FakeHidBus

    devices = DeviceSet(config, clock=clock, hid_api=FakeHidBus([dev])).open()
    clock.advance(3)
    devices.poll()
    status = {s["name"]: s for s in devices.statuses()}
    assert status["knobs"]["state"] == "waiting" and status["knobs"]["missing_s"] == 3.0
    assert status["kb"]["state"] == "connected" and status["kb"]["missing_s"] is None
    dev.plug()
    clock.advance(1)
    devices.poll()
    dev.push(encode_report(layout, deltas={0: 1}))
    devices.poll()
    assert devices.backends[0].state is State.CONNECTED
    dev.unplug()
    devices.poll()
    assert devices.backends[0].state is State.LOST
    devices.close()


def test_controller_unplugged_is_lost_and_back_connected(loop, controller, sim, clock):
    loop.until(lambda: controller.state is State.CONNECTED)
    assert controller.status()["missing_s"] is None
    sim.unplug()
    loop.step()
    assert controller.state is State.LOST
    loop.run(3.0)
    assert controller.state is State.LOST
    assert controller.status()["missing_s"] == pytest.approx(3.0, abs=0.02)
    sim.plug()
    loop.until(lambda: controller.state is State.CONNECTED)
    assert controller.status()["missing_s"] is None


def test_a_port_that_never_answers_is_waiting_and_its_absence_keeps_counting(clock):
    """The port opens (CONNECTING) but no HELLO comes: after 2 s it is closed and reopened,
    again and again; the device counts as missing since the start, not since the last try."""
    master, slave = os.openpty()
    os.set_blocking(master, False)
    b = SerialController(name="c", clock=clock, path=os.ttyname(slave)).open()
    try:
        assert b.state is State.CONNECTING
        loop = Loop(clock, None, [b])
        seen = set()
        for _ in range(1000):
            loop.step()
            seen.add(b.state)
            with contextlib.suppress(BlockingIOError):
                os.read(master, 4096)  # nobody answers the HELLO_REQUESTs
        assert seen == {State.CONNECTING, State.WAITING}
        assert b.state in MISSING and b.missing_seconds() == pytest.approx(10.0, abs=0.02)
        assert b.state_seconds() < 2.6
    finally:
        b.close()
        os.close(master)
        os.close(slave)
