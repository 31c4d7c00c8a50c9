"""Firmware in the loop: the built controller .elf runs in simavr (firmware/sim/harness.c), which
drives its ADC pins and button pins and bridges its UART to a pseudo-terminal. The test opens that
pty with pyserial, as the exhibit opens the real board, and decodes what arrives with
exhibit.devices.protocol.

Simulated time runs at SPEED times real time, or slower when the machine is busy; nothing here
reads the wall clock to judge the board. Every timing check uses the device's own clock
(heartbeat uptime, axes t_ms) or the simulator's (Harness.sim_time); every wait is bounded in
simulated seconds; inputs change at one simulated instant (the CPU paused meanwhile), and the
bytes on the line (Harness.line_bytes) say which frames came after a change, and when the
firmware has a command. The wall clock only catches a simulator that stopped (STALL_S), so a busy
machine makes these tests slower, not flaky."""

from __future__ import annotations

import time

import pytest
import serial

from exhibit.devices import protocol as p
from exhibit.devices.base import Kind, State
from exhibit.devices.controller import SerialController
from exhibit.devices.simavr import BUTTON_PINS, REST_MV, VCC_MV, Harness

from .controller_model import AXIS_TOL, c16, expected_axis

SPEED = 8
WITHIN_S = 5.0  # simulated seconds a wait may take unless it says otherwise (all need under 1 s)
STALL_S = 60.0  # wall seconds with nothing moving: the simulator or the line hung (a backstop)


class Stall:
    """The one use of the wall clock: fails when ``check``'s value stays the same for STALL_S
    seconds. Never a timing check: a busy machine only makes the value move more slowly."""

    def __init__(self, what: str):
        self.what = what
        self.last: object = None
        self.since = time.monotonic()

    def check(self, value: object) -> None:
        now = time.monotonic()
        if value != self.last:
            self.last, self.since = value, now
        elif now - self.since > STALL_S:
            raise AssertionError(f"{self.what}: nothing moved in {STALL_S:g} s (a hang)")


class Host:
    """The exhibit's side: the pty opened with pyserial, bytes through the StreamDecoder."""

    def __init__(self, sim: Harness, path: str):
        self.sim = sim
        self.port = serial.Serial(path, 115200, timeout=0.02)
        self.decoder = p.StreamDecoder()
        self.tracker = p.SequenceTracker()
        self.frames: list[p.Frame] = []
        self._unseen: list[p.Frame] = []  # decoded, not yet looked at by wait_for
        self.received = 0  # bytes read from the pty
        self.seq = 0

    def _read(self, limit: int = 4096) -> None:
        data = self.port.read(limit)
        self.received += len(data)
        self._unseen += [i for i in self.decoder.feed(data) if isinstance(i, p.Frame)]

    def _take(self, pred, since: int) -> p.Frame | None:
        while self._unseen:
            frame = self._unseen.pop(0)
            self.tracker.update(frame)
            self.frames.append(frame)
            if len(self.frames) > since and pred(frame):
                return frame
        return None

    def wait_for(self, pred, within=WITHIN_S, what="frame", since=0) -> p.Frame:
        """Reads until a frame satisfying pred arrives (frames before it are kept in .frames),
        looking only at frames from index ``since`` of .frames on. Fails when ``within``
        seconds of simulated time pass without one, after reading everything sent until then."""
        start = self.sim.sim_time()
        stall = Stall(f"waiting for {what}")
        while True:
            if not self._unseen:
                self._read()
            frame = self._take(pred, since)
            if frame is not None:
                return frame
            now = self.sim.sim_time()
            if now - start > within:
                self.drain(self.sim.line_bytes()[0])
                frame = self._take(pred, since)
                if frame is not None:
                    return frame
                raise AssertionError(
                    f"no {what} within {within:g} s of simulated time; decoder "
                    f"{self.decoder.summary()}, last frames {self.frames[-3:]}")
            stall.check((now, self.received))

    def wait_type(self, cls, pred=lambda m: True, **kw):
        return self.wait_for(lambda f: isinstance(f.message, cls) and pred(f.message),
                             what=cls.__name__, **kw)

    def collect(self, n, cls=None, since=None) -> list[p.Frame]:
        """n frames (of type cls) from index ``since`` of .frames on (default: from now)."""
        start = len(self.frames) if since is None else since

        def enough(f):
            got = self.frames[start:]
            return len(got) >= n and (cls is None or
                                      sum(isinstance(g.message, cls) for g in got) >= n)

        self.wait_for(enough, what=f"{n} {cls.__name__ if cls else 'frame'}s")
        return [f for f in self.frames[start:] if cls is None or isinstance(f.message, cls)]

    def drain(self, upto: int) -> None:
        """Reads (into the frames not yet looked at) until ``upto`` bytes have arrived."""
        stall = Stall(f"reading up to byte {upto}")
        while self.received < upto:
            self._read(upto - self.received)
            stall.check(self.received)

    def mark(self, sent: int) -> int:
        """The index of .frames from which frames began after the line had carried ``sent``
        bytes (a frame cut at that byte counts as before)."""
        self.drain(sent)
        return len(self.frames) + len(self._unseen) + (1 if self.decoder.pending else 0)

    def send(self, msg: p.Message) -> int:
        data = p.encode_frame(msg, self.seq)
        self.port.write(data)
        self.seq += 1
        return len(data)

    def close(self):
        self.port.close()


@pytest.fixture(scope="module")
def board(harness, avr_build, tmp_path_factory):
    sim = Harness(avr_build / "controller" / "controller.elf", harness=harness, speed=SPEED,
                  log=tmp_path_factory.mktemp("sim") / "harness.log", timeout=STALL_S)
    host = None
    try:
        for ch in range(6):
            sim.adc(ch, REST_MV)
        for b in BUTTON_PINS:
            sim.button(b, False)
        host = Host(sim, sim.pty)  # opened before the CPU starts: the boot frames are seen
        sim.run()
        boot_cal = host.wait_type(p.Calibration)
        yield sim, host, boot_cal
    finally:
        if host:
            host.close()
        sim.close()


def change(sim, host, adc=None, buttons=None) -> int:
    """Sets inputs (ADC channel: mV, button: pressed) at one simulated instant, the CPU paused
    meanwhile, and returns the index of host.frames from which frames were sent after it. The
    firmware samples on its next 10 ms tick and may have a frame in its own buffer, so a frame
    or two after the index can still show the old inputs (settled_axes allows for them)."""
    sim.pause()
    try:
        sent, _ = sim.line_bytes()
        for ch, mv in (adc or {}).items():
            sim.adc(ch, mv)
        for b, pressed in (buttons or {}).items():
            sim.button(b, pressed)
    finally:
        sim.run()
    return host.mark(sent)


def delivered(sim, upto: int) -> None:
    """Waits until the harness has read ``upto`` bytes from the host: they are in the
    firmware's UART, which takes them in simulated time from there."""
    stall = Stall(f"the harness reading up to byte {upto} from the host")
    while (taken := sim.line_bytes()[1]) < upto:
        stall.check(taken)
        time.sleep(0.002)


def rest(sim, host, mv=REST_MV):
    """All sticks to mv, buttons released, and wait until the board is idle again."""
    since = change(sim, host, {ch: mv for ch in range(6)}, {b: False for b in BUTTON_PINS})
    host.wait_type(p.Heartbeat, since=since)


def settled_axes(host, pred=lambda a: True, since=None) -> p.Axes:
    """The first axes frame after the filters settled: 60 axes frames from index ``since`` of
    host.frames (default: from now) leave (3/4)^58 of the step, counting two stale frames."""
    host.collect(60, p.Axes, since)
    return host.wait_type(p.Axes, pred).message


def test_boot_sends_hello_then_power_up_calibration(board):
    sim, host, boot_cal = board
    hello, cal = host.frames[0], host.frames[1]
    assert (hello.seq, cal.seq) == (0, 1)
    assert hello.message == p.Hello((1, 1, 0), 1, 6, 5, 100, 250, p.ResetCause.POWER_ON)
    assert cal.message is boot_cal.message
    assert cal.message.reason is p.CalibrationReason.POWER_UP
    assert cal.message.eeprom_mask == 0  # the EEPROM holds no record yet
    assert all(abs(z - c16(REST_MV)) <= 16 for z in cal.message.zeros)
    assert host.decoder.rejected == 0


def test_idle_heartbeat_every_250_ms_and_nothing_else(board):
    sim, host, _ = board
    rest(sim, host)
    start = len(host.frames)
    beats = host.collect(4, p.Heartbeat)
    assert all(isinstance(f.message, p.Heartbeat) for f in host.frames[start:])
    gaps = [b.message.uptime_ms - a.message.uptime_ms for a, b in zip(beats, beats[1:])]
    assert gaps == [250, 250, 250]
    assert [b.seq for b in beats] == [(beats[0].seq + i) & 0xFF for i in range(4)]


def test_axes_follow_the_injected_voltages(board):
    sim, host, boot_cal = board
    rest(sim, host)
    zeros = boot_cal.message.zeros
    volts = [4000, 1000, REST_MV + 30, 500, VCC_MV, 2000]  # axis 2 stays inside the dead zone
    axes = settled_axes(host, since=change(sim, host, dict(enumerate(volts))))
    want = [expected_axis(mv, z) for mv, z in zip(volts, zeros)]
    assert axes.axes[2] == 0 and axes.axes[4] == p.AXIS_FULL_SCALE
    assert all(abs(a - w) <= AXIS_TOL for a, w in zip(axes.axes, want)), (axes.axes, want)
    assert want[0] > 15000 and want[3] < -25000  # the check above is not vacuous

    # 100 Hz by the device clock, no frame lost on the way
    frames = host.collect(20, p.Axes)
    assert {(b.message.t_ms - a.message.t_ms) & 0xFFFF for a, b in zip(frames, frames[1:])} == {10}
    assert all((b.seq - a.seq) & 0xFF == 1 for a, b in zip(frames, frames[1:]))
    assert host.tracker.lost == 0 and host.decoder.rejected == 0


def test_release_lingers_with_zeros_then_heartbeats(board):
    sim, host, _ = board
    rest(sim, host)
    sim.adc(0, 4500)
    host.wait_type(p.Axes, lambda a: a.axes[0] > 20000)
    start = change(sim, host, {0: REST_MV})
    beat = host.wait_type(p.Heartbeat, since=start)
    after = host.frames[start:-1]
    last_moving = max(i for i, f in enumerate(after) if any(f.message.axes))
    zeros = after[last_moving + 1 :]
    assert len(zeros) == 50  # LINGER_MS / 10 ms of all-zero frames: the host sees the release
    assert all(f.message.axes == (0,) * 6 for f in zeros)
    assert (beat.message.uptime_ms - zeros[-1].message.t_ms) & 0xFFFF == 250


def test_buttons_are_debounced_and_reported(board):
    sim, host, _ = board
    rest(sim, host)
    sim.button(3, True)
    pressed = host.wait_type(p.Axes, lambda a: a.buttons)
    assert pressed.message.buttons == 0b0100 and pressed.message.axes == (0,) * 6
    sim.button(3, False)
    host.wait_type(p.Axes, lambda a: a.buttons == 0)
    host.wait_type(p.Heartbeat)  # back to idle: a pressed button alone kept it active


def test_five_buttons_on_pd2_to_pd6_and_nothing_else(board):
    """Button n is PD(n+1) pulled to GND and bit n-1 of AXES: button 5 (PD6, Nano D6) is bit 4,
    all five together are 0b11111, and PD7 (not a button) changes nothing."""
    sim, host, _ = board
    rest(sim, host)
    assert BUTTON_PINS == {1: 2, 2: 3, 3: 4, 4: 5, 5: 6}
    since = change(sim, host, buttons={5: True})
    pressed = host.wait_type(p.Axes, lambda a: a.buttons, since=since).message
    assert pressed.buttons == 0b10000 and pressed.axes == (0,) * 6
    since = change(sim, host, buttons={b: True for b in BUTTON_PINS})
    assert host.wait_type(p.Axes, lambda a: a.buttons == 0b11111, since=since)
    since = change(sim, host, buttons={b: False for b in BUTTON_PINS})
    host.wait_type(p.Heartbeat, since=since)  # all released: idle again
    sim.pause()
    try:
        since = host.mark(sim.line_bytes()[0])
        sim.pin("D", 7, 0)
    finally:
        sim.run()
    host.collect(3, p.Heartbeat, since=since)
    assert all(isinstance(f.message, p.Heartbeat) for f in host.frames[since:])  # no AXES
    sim.pin("D", 7, 1)


def test_button_5_reaches_the_exhibit_as_button_event_4(harness, avr_build, tmp_path):
    """The exhibit's own SerialController on the firmware's pty, on the simulator's clock: the
    hello says 5 buttons, and button 5 (default.toml's input = "button 5") arrives as a BUTTON
    event of index 4, pressed and released, with no other event."""
    sim = Harness(avr_build / "controller" / "controller.elf", harness=harness, speed=SPEED,
                  log=tmp_path / "harness.log", timeout=STALL_S)
    ctl = None
    try:
        for ch in range(6):
            sim.adc(ch, REST_MV)
        for b in BUTTON_PINS:
            sim.button(b, False)
        ctl = SerialController(name="controller", path=sim.pty, clock=sim.sim_time).open()
        sim.run()
        events: list = []

        def poll_until(pred, what):
            start, stall = sim.sim_time(), Stall(f"waiting for {what}")
            while not pred():
                events.extend(ctl.poll())
                now = sim.sim_time()
                assert now - start <= WITHIN_S, f"no {what} in {WITHIN_S:g} s: {ctl.status()}"
                stall.check((now, ctl.bytes_in))
                time.sleep(0.002)

        poll_until(lambda: ctl.state is State.CONNECTED and ctl.calibration is not None, "boot")
        assert ctl.hello.n_buttons == 5 and ctl.capabilities.buttons == 5
        sim.button(5, True)
        poll_until(lambda: events, "the press")
        sim.button(5, False)
        poll_until(lambda: len(events) >= 2, "the release")
        assert [(e.device, e.kind, e.index, e.value) for e in events] == [
            ("controller", Kind.BUTTON, 4, 1.0), ("controller", Kind.BUTTON, 4, 0.0)]
        assert ctl.decoder.rejected == 0 and ctl.tracker.lost == 0
    finally:
        if ctl is not None:
            ctl.close()
        sim.close()


def test_host_commands_and_receive_counters(board):
    sim, host, _ = board
    rest(sim, host)
    before = host.wait_type(p.Heartbeat).message
    _, taken = sim.line_bytes()
    written = host.send(p.HelloRequest())
    hello = host.wait_type(p.Hello).message
    assert hello.reset_cause == p.ResetCause.POWER_ON and hello.firmware == (1, 1, 0)
    bad = bytearray(p.encode_frame(p.HelloRequest(), 9))
    bad[2] ^= 0x01
    junk = b"\x13\x37\x00" + bytes(bad) + p.encode_raw(p.MsgType.HEARTBEAT, 1, b"", version=9)
    host.port.write(junk)
    written += len(junk)
    after = host.wait_type(p.Heartbeat, lambda h: h.rx_rejected >= before.rx_rejected + 3).message
    assert after.rx_ok == before.rx_ok + 1 and after.rx_rejected == before.rx_rejected + 3
    # the harness counts the line's bytes as they pass: what the host wrote, what it was sent
    sent, received = sim.line_bytes()
    assert received - taken == written and sent >= host.received


def test_host_calibration_survives_a_watchdog_reset(board):
    """Calibrate at an off-centre rest, then hang the firmware with the stick held: the watchdog
    resets it, it says so in its hello, and keeps the stored zero for the held axis only."""
    sim, host, boot_cal = board
    rest(sim, host)
    settled_axes(host, since=change(sim, host, {0: 2700}))
    host.send(p.Calibrate())
    cal = host.wait_type(p.Calibration, lambda c: c.reason is p.CalibrationReason.HOST).message
    assert abs(cal.zeros[0] - c16(2700)) <= 16 and cal.eeprom_mask == 0
    assert cal.zeros[1:] == boot_cal.message.zeros[1:]
    host.wait_type(p.Heartbeat)  # 2.7 V is the new rest: the board goes idle

    held = settled_axes(host, since=change(sim, host, {0: 4000})).axes[0]  # a visitor holds
    assert abs(held - expected_axis(4000, cal.zeros[0])) <= AXIS_TOL  # the stick ...

    # ... while the firmware hangs. The command goes through the pty with the CPU paused, and
    # the CPU runs again once the harness has it: the firmware sees it from t_cmd on.
    sim.pause()
    frames_before, (_, taken) = len(host.frames), sim.line_bytes()
    delivered(sim, taken + host.send(p.WatchdogTest()))
    t_cmd = sim.sim_time()
    sim.run()
    hello = host.wait_type(p.Hello)
    assert hello.seq == 0 and hello.message.reset_cause == p.ResetCause.WATCHDOG
    sim.sim_time()  # a reply after the reset's notice: sim.resets has it
    # WDTO_250MS (256 ms of the 128 kHz oscillator) from the wdt_reset of the 10 ms tick that
    # read the command, which started within a tick of the command's last byte
    assert len(sim.resets) == 1 and 0.25 <= sim.resets[0] - t_cmd <= 0.275
    boot = host.wait_type(p.Calibration).message
    assert boot.reason is p.CalibrationReason.POWER_UP
    assert boot.eeprom_mask == 0b000001  # axis 0 held at power-up: stored zero kept
    assert boot.zeros[0] == cal.zeros[0]
    assert all(abs(z - c16(REST_MV)) <= 16 for z in boot.zeros[1:])
    again = settled_axes(host).axes[0]
    assert abs(again - held) <= AXIS_TOL  # same reading as before the reset
    assert host.tracker.restarts == 1
    assert all(not isinstance(f.message, p.Hello) or f is hello for f in host.frames[frames_before:])
    # anything cut off by the reset was rejected, never accepted
    assert host.decoder.rejected <= 1

    # leave the board calibrated at the common rest for the other tests
    settled_axes(host, since=change(sim, host, {0: REST_MV}))
    host.send(p.Calibrate())
    host.wait_type(p.Calibration, lambda c: c.reason is p.CalibrationReason.HOST)
    host.wait_type(p.Heartbeat)


def test_button_gesture_stores_the_zero(board):
    sim, host, _ = board
    rest(sim, host)
    settled_axes(host, since=change(sim, host, {1: 2300}))
    pressed = change(sim, host, buttons={1: True, 2: True})
    t0 = host.wait_type(p.Axes, lambda a: a.buttons == 0b11, since=pressed).message.t_ms
    cal = host.wait_type(p.Calibration, within=3 + WITHIN_S).message
    t1 = host.wait_type(p.Axes).message.t_ms
    assert cal.reason is p.CalibrationReason.BUTTONS
    assert abs(cal.zeros[1] - c16(2300)) <= 16
    assert 2990 <= (t1 - t0) & 0xFFFF <= 3030  # held 3 s
    released = change(sim, host, buttons={1: False, 2: False})
    host.wait_type(p.Heartbeat, since=released)  # 2.3 V on axis 1 now reads as rest
