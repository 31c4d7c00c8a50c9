"""Fixtures for the device tests: simulated time, the controller simulator on a real pty, and a
loop that steps both.

Most tests run the simulator and the host on one fake clock, stepped in 10 ms ticks: the bytes
cross a real pseudo-terminal (the kernel moves them synchronously), but no test sleeps or depends
on how fast the machine is, and "within 2 s" is measured on that clock."""

from __future__ import annotations

import pytest

from exhibit.devices.controller import SerialController
from exhibit.devices.sim import SimController


class FakeClock:
    def __init__(self, t: float = 1000.0):
        self.t = t

    def __call__(self) -> float:
        return self.t

    def advance(self, dt: float) -> None:
        self.t += dt


class Loop:
    """One simulator and any number of backends on one fake clock."""

    def __init__(self, clock, sim=None, backends=()):
        self.clock, self.sim, self.backends = clock, sim, list(backends)
        self.events = []

    def step(self, dt=0.01):
        self.clock.advance(dt)
        if self.sim is not None:
            self.sim.tick()
        for b in self.backends:
            out = getattr(b, "bytes_out", 0)
            self.events += b.poll()
            if self.sim is not None and getattr(b, "bytes_out", 0) > out:
                self.sim.wait_from_host(b.bytes_out - out)

    def run(self, seconds, dt=0.01):
        for _ in range(round(seconds / dt)):
            self.step(dt)

    def until(self, pred, limit=5.0, dt=0.01, what="condition"):
        """Steps until pred() holds; returns the simulated seconds it took."""
        start = self.clock.t
        while not pred():
            if self.clock.t - start > limit:
                raise AssertionError(
                    f"no {what} within {limit} s of simulated time; "
                    f"{[b.status() for b in self.backends]}"
                )
            self.step(dt)
        return self.clock.t - start


@pytest.fixture
def clock():
    return FakeClock()


@pytest.fixture
def sim(clock, tmp_path):
    s = SimController(
        tmp_path / "by-id" / "usb-Exhibit_Controller-if00", clock=clock, seed=1, sync=True
    )
    s.link.parent.mkdir()
    s.plug()
    yield s
    s.stop()


@pytest.fixture
def controller(sim, clock):
    b = SerialController(name="controller", clock=clock, path=str(sim.link))
    b.open()
    yield b
    b.close()


@pytest.fixture
def loop(clock, sim, controller):
    return Loop(clock, sim, [controller])
