"""Long runs (marked slow; CI runs them): 1,000 unplug/replug cycles without descriptor or
memory growth, 10^6 random bytes through the serial backend, and a quick hypothesis fuzz of the
HID report parser that runs by default."""

from __future__ import annotations

import gc
import os
import random
import tracemalloc

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.devices import protocol as p
from exhibit.devices.base import Kind, State
from exhibit.devices.fakehid import FakeHidBus, FakeHidDevice
from exhibit.devices.hid import HidBackend, load_layouts
from tests.hypothesis_profiles import examples

from .conftest import FakeClock, Loop

LAYOUTS = load_layouts()


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


@pytest.mark.slow
def test_1000_serial_unplug_cycles_leak_nothing(loop, controller, sim):
    def cycle(i):
        sim.set_axes([0.5 if i % 2 else -0.5, 0, 0, 0, 0, 0])
        sim.unplug()
        loop.step()
        assert controller.state is State.LOST
        sim.plug()
        assert loop.until(lambda: controller.state is State.CONNECTED) <= 2.0
        del loop.events[:]

    loop.until(lambda: controller.state is State.CONNECTED)
    for i in range(20):  # warm up caches, interned strings, the allocator
        cycle(i)
    gc.collect()
    fds = open_fds()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    for i in range(1000):
        cycle(i)
    gc.collect()
    grown = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    assert open_fds() == fds
    assert grown < 200_000, f"{grown} bytes more after 1000 cycles"
    assert controller.reconnects == 1020


@pytest.mark.slow
def test_1000_hid_unplug_cycles_leak_nothing():
    clock = FakeClock()
    layout = LAYOUTS["knobbox"]
    dev = FakeHidDevice(0x2341, 0x8037, clock=clock, layout=layout)
    bus = FakeHidBus([dev])
    b = HidBackend(name="k", clock=clock, layout=layout, vid=0x2341, pid=0x8037, api=bus).open()
    loop = Loop(clock, None, [b])

    def cycle():
        dev.push(bytes.fromhex("010100000000000001"))
        loop.step()
        dev.unplug()
        loop.step()
        dev.plug()
        assert loop.until(lambda: b.state is State.CONNECTED) <= 2.0
        del loop.events[:]

    for _ in range(20):
        cycle()
    gc.collect()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    for _ in range(1000):
        cycle()
    gc.collect()
    grown = tracemalloc.get_traced_memory()[0] - base
    tracemalloc.stop()
    assert bus.open_handles == 1 and grown < 100_000


@pytest.mark.slow
def test_a_million_random_bytes_with_frames_between(loop, controller, sim):
    """10^6 random bytes over the pty, a valid AXES frame after each burst: never a crash, no
    random chunk accepted, every frame behind a delimiter recovered, the link never dropped."""
    loop.until(lambda: controller.state is State.CONNECTED)
    sim.hang(1e9)  # the simulator goes quiet; the test owns the line
    rng = random.Random(1234)
    sent = []
    total = 0
    seq = 0
    while total < 1_000_000:
        junk = rng.randbytes(rng.randrange(1, 3000))
        total += len(junk)
        value = rng.randrange(-32767, 32768) or 1
        sent.append(value / p.AXIS_FULL_SCALE)
        sim.inject(junk + b"\x00" + p.encode_frame(p.Axes(seq & 0xFFFF, (value,) * 6, 0), seq))
        seq += 1
        while controller.decoder.pending or controller.bytes_in < sim_written(sim):
            before = controller.bytes_in
            loop.events += controller.poll()
            if controller.bytes_in == before:
                break
        # keep the link alive: the test's own frames count as traffic
        loop.clock.advance(0.001)
    got = [e.value for e in loop.events if e.kind is Kind.ABS and e.index == 0]
    dedup = [v for i, v in enumerate(sent) if i == 0 or v != sent[i - 1]]
    assert got == dedup
    assert controller.state is State.CONNECTED
    assert controller.decoder.frames_ok >= len(sent)
    assert controller.decoder.rejected > 0


def sim_written(sim) -> int:
    return sim.bytes_written


@settings(max_examples=examples(200), deadline=None)
@given(st.lists(st.binary(max_size=70), max_size=20), st.sampled_from(sorted(LAYOUTS)))
def test_random_hid_reports_never_crash(reports, name):
    clock = FakeClock()
    layout = LAYOUTS[name]
    vid, pid = layout.match[0]
    dev = FakeHidDevice(vid, pid, clock=clock, layout=layout)
    b = HidBackend(
        name="h", clock=clock, layout=layout, vid=vid, pid=pid, api=FakeHidBus([dev])
    ).open()
    dev.push(*[r for r in reports if r])
    events = b.poll()
    assert b.reports_ok + b.reports_unknown == len([r for r in reports if r])
    assert all(-1.0 <= e.value <= 1.0 for e in events if e.kind is not Kind.REL)
    assert all(e.value != 0 for e in events if e.kind is Kind.REL)
