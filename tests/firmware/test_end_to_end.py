"""The hardware path end to end: the controller firmware in simavr, its UART on a pty, the
exhibit's SerialController reading it, the shipped mapping turning events into a ViewState.

Nothing here is a stand-in for the exhibit's code: the bytes are the firmware's own, the host
is the class the kiosk runs. The simulated CPU runs at real time (the host's timeouts are real
time), and each test starts a fresh board from an EEPROM image its fixture wrote (erased, or a
known calibration), so the tests share no state and pass in any order.

The same tests run against a real board (firmware/README.md, "Checking a board"): set
EXHIBIT_BOARD=/dev/ttyACM0 (default when that port exists). Tests that need to set stick
voltages or power-cycle the board are skipped there; the others (handshake, heartbeat, the
watchdog reset in a stream, calibration across a restart) run unchanged.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import pytest

from exhibit.devices import protocol as p
from exhibit.devices.base import Kind, State
from exhibit.devices.config import load_config
from exhibit.devices.controller import SerialController
from exhibit.devices.mapping import PARAMS, Mapper, shape
from exhibit.devices.simavr import EEPROM_SIZE, REST_MV, FirmwareController
from exhibit.geometry.view import ViewState

from .conftest import ROOT
from .controller_model import AXIS_TOL, c16, calib_record, expected_axis, read_calib_record

pytestmark = pytest.mark.slow

CONFIG = ROOT / "configs" / "devices" / "default.toml"
REAL_BOARD = os.environ.get("EXHIBIT_BOARD", "/dev/ttyACM0")
KNOWN_ZEROS = (8000, 8300, 8176, 8100, 8250, 8176)  # c16, all near mid-scale
# Wall seconds a wait may take before it counts as a hang. A busy machine runs the simulated
# board and the host late; the waits end on the condition, and only the explicit limits below
# (the host's own real-time promises: loss after 4 heartbeats, replug within 2 s) are timings.
HANG_S = 60.0


class RecordingTracker(p.SequenceTracker):
    """The controller's sequence tracker, keeping every frame the host accepted."""

    def __init__(self):
        super().__init__()
        self.frames: list[p.Frame] = []

    def update(self, frame):
        self.frames.append(frame)
        return super().update(frame)


class Rig:
    """The exhibit's input path as the kiosk runs it: poll the backend, map the events, step
    the view; a history of (time, view, events) for the assertions."""

    def __init__(self, link: Path):
        config = load_config(CONFIG)
        self.bindings = [b for b in config.mapping.bindings if b.device == "controller"]
        self.mapper = Mapper(config.mapping)
        self.view = ViewState()
        self.ctl = SerialController(name="controller", path=str(link))
        self.ctl.tracker = RecordingTracker()
        self.events: list = []
        self.history: list[tuple[float, ViewState]] = []
        self.ctl.open()

    def step(self, dt=0.005):
        time.sleep(dt)
        now = time.monotonic()
        events = self.ctl.poll()
        self.events += events
        self.view = self.mapper.apply(self.view, events, now)
        self.history.append((now, self.view))
        return now

    def run(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.step()

    def until(self, pred, limit=HANG_S, what="condition") -> float:
        """Steps until pred() holds; the seconds it took."""
        start = time.monotonic()
        while not pred():
            if time.monotonic() - start > limit:
                raise AssertionError(f"no {what} within {limit} s: {self.ctl.status()}")
            self.step()
        return time.monotonic() - start

    def connected(self) -> float:
        return self.until(lambda: self.ctl.state is State.CONNECTED, what="handshake")

    def settled(self, pred=lambda axes: True, limit=HANG_S):
        """Waits until the axes stopped changing (no ABS event for 0.3 s) and pred holds."""
        def quiet():
            abs_times = [e.t for e in self.events if e.kind is Kind.ABS]
            last = abs_times[-1] if abs_times else 0.0
            return time.monotonic() - last > 0.3 and pred(self.axes())
        self.until(quiet, limit, "settled axes")
        return self.axes()

    def axes(self) -> list[float]:
        return [self.ctl._axes.get(i, 0.0) for i in range(6)]

    def param(self, name: str, view=None) -> float:
        view = view or self.view
        return view.sensor_r if name == "sensor" else math.degrees(view.angles[PARAMS.index(name)])

    def rates(self, seconds: float) -> dict[str, float]:
        """Degrees (sensor: r) per second each parameter moved over the next ``seconds``."""
        t0, before = self.step(), self.view
        total, t, last = dict.fromkeys(PARAMS, 0.0), t0, before
        while t - t0 < seconds:
            t = self.step()
            for name in PARAMS:
                d = self.param(name) - self.param(name, last)
                if name != "sensor":
                    d = math.remainder(d, 360.0)  # across the +-180 wrap
                total[name] += d
            last = self.view
        return {name: v / (t - t0) for name, v in total.items()}

    def rate_of(self, name: str, seconds: float) -> float:
        return self.rates(seconds)[name]

    def turning_axis(self) -> tuple[int, str]:
        """An axis the mapping binds to an angle, and that angle."""
        b = next(b for b in self.bindings if b.kind is Kind.ABS and b.param != "sensor")
        return b.index, b.param

    def expected_rate(self, param: str, axes: list[float]) -> float:
        r = 0.0
        for b in self.bindings:
            if b.kind is Kind.ABS and b.param == param:
                v = shape(axes[b.index], b.dead_zone, b.curve) * b.rate
                r += -v if b.invert else v
        return r

    def close(self):
        self.ctl.close()


class Board:
    """The board under test: the firmware in simavr, or a real one on a serial port."""

    def __init__(self, sim: FirmwareController | None, path: Path):
        self.sim, self.link = sim, path

    def connect(self, rigs) -> "Rig":
        """The host opens the port, then the board powers up: the host sees it boot, and its
        power-up calibration (sticks moved before it are taken for the rest position)."""
        rig = rigs(self.link)
        if self.sim is not None:
            self.sim.run()
        rig.connected()
        if self.sim is not None:
            rig.until(lambda: rig.ctl.calibration is not None, what="power-up calibration")
        return rig

    def needs_inputs(self):
        if self.sim is None:
            pytest.skip("sets stick voltages or power-cycles the board: simavr only")


def eeprom_image(zeros=None) -> bytes:
    image = bytearray(b"\xff" * EEPROM_SIZE)
    if zeros is not None:
        image[: len(calib_record(zeros))] = calib_record(zeros)
    return bytes(image)


@pytest.fixture(params=["simavr", "real"])
def make_board(request, avr_build, harness, tmp_path):
    """A factory: make_board(zeros=None, volts=None) starts a board from an erased EEPROM, or
    from one that holds a calibration record with these zeros, with these {channel: mV} on its
    sticks (the rest at mid-scale)."""
    started = []

    def make(zeros=None, volts=None) -> Board:
        if request.param == "real":
            if not Path(REAL_BOARD).exists():
                pytest.skip(f"no board on {REAL_BOARD} (set EXHIBIT_BOARD)")
            return Board(None, Path(REAL_BOARD))
        eeprom = tmp_path / "eeprom.bin"
        eeprom.write_bytes(eeprom_image(zeros))
        sim = FirmwareController(avr_build / "controller" / "controller.elf",
                                 tmp_path / "by-id" / "usb-Exhibit_Controller-if00",
                                 harness=harness, eeprom=eeprom, log_dir=tmp_path)
        sim.link.parent.mkdir(exist_ok=True)
        started.append(sim)
        for ch, mv in (volts or {}).items():
            sim.set_volts(ch, mv)
        sim.plug(run=False)  # the CPU starts once the host has the port open (Board.connect)
        return Board(sim, sim.link)

    yield make
    for sim in started:
        sim.stop()


@pytest.fixture
def rigs():
    made = []

    def make(link):
        made.append(Rig(link))
        return made[-1]

    yield make
    for rig in made:
        rig.close()


def test_board_boots_from_erased_eeprom_and_hands_over_its_hello(make_board, rigs):
    board = make_board()
    rig = rigs(board.link)
    if board.sim is not None:
        board.sim.run()
    assert rig.connected() < 2.0
    assert rig.ctl.hello.firmware == (1, 1, 0) and rig.ctl.hello.heartbeat_ms == 250
    rig.run(1.0)  # idle: heartbeats keep it connected, no events, the view stands still
    assert rig.ctl.state is State.CONNECTED and rig.events == []
    assert rig.view == ViewState()
    if board.sim is not None:
        assert rig.until(lambda: rig.ctl.calibration is not None, what="calibration") < 1.0
        assert rig.ctl.calibration.eeprom_mask == 0


def test_voltages_move_the_view_as_the_mapping_says(make_board, rigs):
    board = make_board()
    board.needs_inputs()
    rig = board.connect(rigs)
    rig.until(lambda: rig.ctl.calibration is not None, what="calibration")
    zeros = rig.ctl.calibration.zeros
    volts = {0: 4000, 1: 1200, 2: REST_MV + 30, 5: 4500}  # axis 3 inside the dead zone
    for ch, mv in volts.items():
        board.sim.set_volts(ch, mv)
    axes = rig.settled(lambda a: a[0] > 0.3)
    for ch in range(6):
        want = expected_axis(volts.get(ch, REST_MV), zeros[ch]) / p.AXIS_FULL_SCALE
        assert axes[ch] == pytest.approx(want, abs=AXIS_TOL / p.AXIS_FULL_SCALE), (ch, axes)
    assert axes[2] == 0 and axes[0] > 0.5 and axes[1] < -0.5 and axes[5] > 0.7
    assert any(rig.expected_rate(n, axes) for n in PARAMS)  # the mapping binds these axes
    measured = rig.rates(0.5)
    for name in PARAMS[:6]:
        assert measured[name] == pytest.approx(rig.expected_rate(name, axes), rel=0.01, abs=1e-9), name
    # the sensor moves in r within [0, 1/sensor_min_distance]: compare while it is inside
    r_max = rig.mapper.config.sensor_r_max
    want = rig.expected_rate("sensor", axes)
    if want > 0 and rig.view.sensor_r < r_max / 2:
        assert measured["sensor"] == pytest.approx(want, rel=0.01)
    elif want <= 0:
        assert rig.view.sensor_r == 0.0


def test_a_held_stick_keeps_turning_at_its_rate(make_board, rigs):
    board = make_board()
    board.needs_inputs()
    rig = board.connect(rigs)
    ch, param = rig.turning_axis()
    board.sim.set_volts(ch, 1000)
    axes = rig.settled(lambda a: a[ch] < -0.3)
    want = rig.expected_rate(param, axes)
    n_events = len(rig.events)
    rates = [rig.rate_of(param, 1.0) for _ in range(3)]
    assert rates == pytest.approx([want] * 3, rel=0.01)
    assert abs(want) > 20
    assert len(rig.events) == n_events  # the held value streams on, unchanged: no new events
    assert rig.ctl.state is State.CONNECTED and rig.ctl.tracker.lost == 0


def test_heartbeat_loss_is_detected_within_four_periods(make_board, rigs):
    """The CPU stops (a hung board, the port still open): LOST after 4 x 250 ms of silence, not
    before, and the board is back once it runs again."""
    board = make_board()
    board.needs_inputs()
    rig = board.connect(rigs)
    rig.run(0.6)
    paused = time.monotonic()
    board.sim.harness.pause()
    rig.until(lambda: rig.ctl.state is State.LOST, limit=3.0, what="loss")
    last = rig.ctl.tracker.frames[-1]
    assert isinstance(last.message, p.Heartbeat)
    lost_at = rig.ctl._state_since
    silent = lost_at - rig.ctl._last_rx  # from the poll that read the last frame to LOST
    polls = [t for t, _ in rig.history if t <= lost_at]  # up to the poll that noticed
    gap = polls[-1] - polls[-2]  # the poll interval at detection
    print(f"loss detected {silent:.3f} s after the last frame (poll interval {gap * 1000:.1f} ms), "
          f"{lost_at - paused:.3f} s after the CPU stopped")
    assert rig.ctl.lost_after == 1.0
    assert 1.0 < silent <= 1.0 + gap + 0.002  # at the first poll past four heartbeat periods
    assert 0.75 - 0.05 <= lost_at - paused <= silent + 0.05  # the last heartbeat came <= 250 ms before
    board.sim.harness.run()
    assert rig.until(lambda: rig.ctl.state is State.CONNECTED, what="resume") <= 3.0


def test_unplug_releases_and_replug_reconnects_within_2_s(make_board, rigs):
    """A stick held through an unplug: released at once, nothing turns while the board is
    gone, and after the replug it turns again (the stored zero is kept for a held stick)."""
    board = make_board(KNOWN_ZEROS)
    board.needs_inputs()
    rig = board.connect(rigs)
    ch, param = rig.turning_axis()
    board.sim.set_volts(ch, 4200)
    board.sim.set_buttons(0b0100)
    rig.settled(lambda a: a[ch] > 0.5)
    board.sim.unplug(hard=True)  # the cable pulled: the pty is gone
    rig.until(lambda: rig.ctl.state is State.LOST, limit=0.5, what="unplug noticed")
    assert rig.axes() == [0.0] * 6 and rig.ctl._buttons == {}  # released: nothing keeps turning
    t_lost = rig.param(param)
    rig.run(1.0)
    assert rig.param(param) == t_lost and rig.ctl.state is State.LOST
    start = time.monotonic()
    board.sim.plug()  # same stable name, a new pty, the board boots
    rig.until(lambda: rig.ctl.state is State.CONNECTED, limit=4.0, what="reconnect")
    took = time.monotonic() - start
    print(f"reconnect after replug: {took:.3f} s")
    assert took <= 2.0
    assert rig.ctl.reconnects == 1
    rig.settled(lambda a: a[ch] > 0.5)  # the stick is still held: it turns again
    assert rig.ctl._buttons.get(2) == 1.0


def test_watchdog_reset_mid_stream_is_survived(make_board, rigs):
    """The firmware hangs while a stick streams; the watchdog resets it. The host resyncs on the
    new HELLO, accepts no frame twice, and the view never jumps: it stops while the board is
    down and turns on at the same rate afterwards."""
    board = make_board(KNOWN_ZEROS)
    rig = board.connect(rigs)
    ch, param = rig.turning_axis()
    if board.sim is not None:
        board.sim.set_volts(ch, 4000)
        axes = rig.settled(lambda a: a[ch] > 0.4)
        rate = rig.expected_rate(param, axes)
        assert rig.rate_of(param, 0.3) == pytest.approx(rate, rel=0.01)
    else:
        rig.run(0.5)
    n = len(rig.ctl.tracker.frames)
    rig.ctl.send(p.WatchdogTest())
    rig.until(lambda: any(isinstance(f.message, p.Hello) and f.seq == 0
                          for f in rig.ctl.tracker.frames[n:]), what="HELLO after reset")
    rig.until(lambda: any(isinstance(f.message, p.Calibration)
                          for f in rig.ctl.tracker.frames[n:]), what="CALIBRATION after reset")
    hello = next(f for f in rig.ctl.tracker.frames[n:] if isinstance(f.message, p.Hello))
    assert hello.message.reset_cause & p.ResetCause.WATCHDOG
    cal = next(f.message for f in rig.ctl.tracker.frames[n:] if isinstance(f.message, p.Calibration))
    assert cal.reason is p.CalibrationReason.POWER_UP
    rig.run(1.0)
    assert rig.ctl.state is State.CONNECTED
    assert rig.ctl.tracker.restarts == 1 and rig.ctl.tracker.duplicates == 0
    assert rig.ctl.tracker.lost == 0 and rig.ctl.decoder.rejected <= 1

    # no frame accepted twice: within each boot the sequence numbers and the device clock only
    # go forward, and nothing from before the reset turns up after it
    frames = rig.ctl.tracker.frames
    boots, cur = [], []
    for f in frames:
        if isinstance(f.message, p.Hello) and f.seq == 0 and cur:
            boots.append(cur)
            cur = []
        cur.append(f)
    boots.append(cur)
    for frames_of_boot in boots:
        seqs = [f.seq for f in frames_of_boot if not isinstance(f.message, p.Hello) or f.seq]
        assert all((b - a) & 0xFF == 1 for a, b in zip(seqs, seqs[1:])), seqs
        ts = [f.message.t_ms for f in frames_of_boot if isinstance(f.message, p.Axes)]
        assert all(0 < (b - a) & 0xFFFF < 1000 for a, b in zip(ts, ts[1:])), ts
    assert len(boots) == 2

    if board.sim is not None:
        # the stick was held through the reset: the stored zero is kept for it, the reading
        # after the reset is the reading before, and the view turns at the same rate again
        assert cal.eeprom_mask == 1 << ch and cal.zeros[ch] == KNOWN_ZEROS[ch]
        after = rig.settled(lambda a: a[ch] > 0.4)
        assert after[ch] == pytest.approx(expected_axis(4000, KNOWN_ZEROS[ch]) / p.AXIS_FULL_SCALE,
                                          abs=AXIS_TOL / p.AXIS_FULL_SCALE)
        rate_after = rig.expected_rate(param, after)
        assert rig.rate_of(param, 0.3) == pytest.approx(rate_after, rel=0.01)
        # no jump: between two polls the view never turned more than the stick's rate allows
        top = max(abs(rate), abs(rate_after))
        for (t0, v0), (t1, v1) in zip(rig.history, rig.history[1:]):
            d = abs(math.remainder(rig.param(param, v1) - rig.param(param, v0), 360.0))
            assert d <= top * (t1 - t0) * 1.01 + 1e-9, (t1, d)


def test_calibration_is_written_and_read_back_across_a_restart(make_board, rigs):
    """CALIBRATE stores the current rest in EEPROM; after a power cycle with the stick held the
    board keeps that stored zero for it (and says so), and measures the others afresh."""
    board = make_board()
    board.needs_inputs()
    rig = board.connect(rigs)
    rig.until(lambda: rig.ctl.calibration is not None, what="boot calibration")
    assert rig.ctl.calibration.eeprom_mask == 0
    assert read_calib_record(board.sim.eeprom.read_bytes()) is None  # erased
    board.sim.set_volts(1, 2800)  # a pot that rests off centre
    rig.settled(lambda a: a[1] > 0)
    rig.ctl.send(p.Calibrate())
    rig.until(lambda: rig.ctl.calibration.reason is p.CalibrationReason.HOST, what="CALIBRATION")
    stored = rig.ctl.calibration.zeros
    assert abs(stored[1] - c16(2800)) <= 16
    rig.settled(lambda a: a[1] == 0)  # 2.8 V is the new rest
    rig.run(0.3)  # the EEPROM image is written back within a few ms
    assert read_calib_record(board.sim.eeprom.read_bytes()) == tuple(stored)

    board.sim.unplug()
    rig.until(lambda: rig.ctl.state is State.LOST, what="unplug noticed")
    board.sim.set_volts(1, 4500)  # held while the exhibit powers up
    board.sim.plug(run=False)
    rig.until(lambda: rig.ctl._port is not None, what="port reopened")
    board.sim.run()
    rig.until(lambda: rig.ctl.state is State.CONNECTED and rig.ctl.calibration is not None
              and rig.ctl.calibration.reason is p.CalibrationReason.POWER_UP
              and rig.ctl.hello.reset_cause == p.ResetCause.POWER_ON, what="boot after replug")
    cal = rig.ctl.calibration
    assert cal.eeprom_mask == 0b000010 and cal.zeros[1] == stored[1]
    assert all(abs(z - c16(REST_MV)) <= 16 for i, z in enumerate(cal.zeros) if i != 1)
    axes = rig.settled(lambda a: a[1] > 0.5)
    assert axes[1] == pytest.approx(expected_axis(4500, stored[1]) / p.AXIS_FULL_SCALE,
                                    abs=AXIS_TOL / p.AXIS_FULL_SCALE)


def test_a_known_calibration_is_kept_for_a_stick_held_at_power_up(make_board, rigs):
    board = make_board(KNOWN_ZEROS, volts={4: 800})
    board.needs_inputs()
    rig = board.connect(rigs)
    rig.until(lambda: rig.ctl.calibration is not None, what="calibration")
    cal = rig.ctl.calibration
    assert cal.eeprom_mask == 0b010000 and cal.zeros[4] == KNOWN_ZEROS[4]
    # the others are near the stored zeros (within tolerance): the measurement wins there
    assert all(abs(z - c16(REST_MV)) <= 16 for i, z in enumerate(cal.zeros) if i != 4)


def test_reset_button_and_line_noise(make_board, rigs):
    """The script's `reset` (the reset pin) and `garbage` (noise towards the host): the board
    says why it restarted, the host resyncs, and the noise is rejected, not taken for frames."""
    board = make_board()
    board.needs_inputs()
    rig = board.connect(rigs)
    n = len(rig.ctl.tracker.frames)
    board.sim.reset()
    rig.until(lambda: any(isinstance(f.message, p.Hello) and f.seq == 0
                          for f in rig.ctl.tracker.frames[n:]), what="HELLO after reset")
    assert rig.ctl.hello.reset_cause == p.ResetCause.EXTERNAL
    assert rig.ctl.tracker.restarts == 1
    m = len(rig.ctl.tracker.frames)
    rig.until(lambda: any(isinstance(f.message, p.Heartbeat) for f in rig.ctl.tracker.frames[m:]),
              what="heartbeat")
    board.sim.harness.pause()  # just after a heartbeat: the line is idle, no frame is cut
    ok, rejected = rig.ctl.decoder.frames_ok, rig.ctl.decoder.rejected
    board.sim.inject(bytes(range(1, 40)) + b"\x00" + bytes([0x05, 0x01, 0x02, 0x03, 0x04, 0x00]))
    board.sim.harness.run()
    rig.run(0.6)
    assert rig.ctl.decoder.rejected == rejected + 2  # the two chunks of noise
    assert rig.ctl.decoder.frames_ok > ok and rig.ctl.state is State.CONNECTED
    assert rig.events == []
